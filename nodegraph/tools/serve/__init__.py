"""`sketchgraph serve PIPELINE`: a live authoring view in the browser (docs/serve.md).

`engine.py`: the render thread (it owns the GL context; requests queue to it; edits coalesce); `app.py`: the
Starlette app (token, Host and Origin checks; the page; one websocket per page); `yamledit.py`: "save
parameters" writes values back into the YAML text, keeping its comments and order; `static/`: the page (plain
HTML, CSS and JavaScript modules, no build step).
"""

from __future__ import annotations

import socket
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .engine import Engine

__all__ = ["Engine", "Server", "serve"]


class Server:
    """A bound socket, the render thread and the app; `run()` serves until interrupted (or `stop()`)."""

    def __init__(self, pipeline_path: Path, open_pipeline: Callable[[tuple[str, ...]], Any], *, cache: Any = None,
                 roots: list[Path] | None = None, host: str = "127.0.0.1", port: int = 8765, frame: int = 0,
                 poll: float = 0.25, token: str | None = None, prefetch: bool = True):
        import uvicorn

        from .app import make_app, new_token

        self.token = token or new_token()
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        # created as TCP by name: asyncio turns Nagle's algorithm off (TCP_NODELAY) only on sockets whose protocol
        # says TCP, and with it on, a picture sent after a small message (a buffer's statistics) waited for the
        # page's delayed acknowledgement, about 40 ms; set on the listening socket too (accepted ones inherit it)
        self.sock = socket.socket(family, socket.SOCK_STREAM, socket.IPPROTO_TCP)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.sock.bind((host, port))
        self.sock.listen(128)  # connections made after the address is printed wait here for uvicorn
        self.port = self.sock.getsockname()[1]
        self.host = host
        shown = f"[{host}]" if ":" in host else host
        hosts: set[str] | None = None  # a wider address: the page is reached by whatever name the network uses
        if host in ("127.0.0.1", "::1", "localhost"):
            hosts = {f"127.0.0.1:{self.port}", f"localhost:{self.port}", f"[::1]:{self.port}"}
        self.url = f"http://{shown}:{self.port}/?token={self.token}"
        self.engine = Engine(pipeline_path, open_pipeline=open_pipeline, cache=cache, roots=roots, poll=poll,
                             frame=frame, prefetch=prefetch)
        self.app = make_app(self.engine, self.token, self.port, hosts)
        # no per-message deflate: views go out as PNGs (already deflated, `engine.encode_png`), and deflating
        # anything larger per message costs more than sending it on the loopback
        config = uvicorn.Config(self.app, log_level="warning", ws="websockets-sansio", lifespan="off",
                                ws_max_size=1 << 20, ws_per_message_deflate=False)
        self.server = uvicorn.Server(config)

    def run(self) -> None:
        self.engine.start()
        try:
            self.server.run(sockets=[self.sock])
        finally:
            self.engine.stop()
            self.sock.close()

    def stop(self) -> None:
        self.server.should_exit = True


def serve(pipeline: str, *, overrides: tuple[str, ...] = (), size: str | None = None, scene: str | None = None,
          out_dir: Path | None = None, view: str | None = None, up: str | None = None, fill: float | None = None,
          cache: Any = None, host: str = "127.0.0.1", port: int = 8765, frame: int = 0, prefetch: bool = True,
          echo: Callable[[str], None] = print) -> None:
    """Serve a pipeline (a path or a shipped pipeline's name) until interrupted."""
    from ...errors import SketchgraphError
    from ...render import open_pipeline
    from ...shipped import resolve

    try:
        import starlette  # noqa: F401
        import uvicorn  # noqa: F401
        import websockets  # noqa: F401
    except ImportError as exc:
        raise SketchgraphError(f"sketchgraph serve needs the package {exc.name}: pip install "
                               "'sketchgraph[serve]'") from None

    path = Path(resolve(pipeline)).resolve()
    out = Path(out_dir).resolve() if out_dir else Path.cwd().resolve()
    roots = [path.parent, out]
    if scene and not scene.startswith("builtin:"):
        roots.append(Path(scene).expanduser().resolve().parent)

    def load(extra: tuple[str, ...]) -> Any:
        return open_pipeline(str(path), tuple(overrides) + extra, size, scene, out_dir=out, allow_outside=False,
                             view=view, up=up, fill=fill)

    server = Server(path, load, cache=cache, roots=roots, host=host, port=port, frame=frame, prefetch=prefetch)
    echo(f"serving {path.name} at {server.url}")
    echo("(Ctrl-C stops it)")
    server.run()
