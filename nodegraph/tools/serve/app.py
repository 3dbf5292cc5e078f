"""The web side of `sketchgraph serve`: a Starlette app (run by uvicorn) with the page, its modules and one
websocket per page.

Security: every HTTP request and websocket must carry the server's random token (`?token=` or the cookie the
page sets, named after the port); on a loopback address the Host header must name the server (no DNS
rebinding); an Origin header, where sent, must be the origin the request is addressed to; anything else is
answered 403. The page and its modules are the
package's own files, served from a fixed list: no request names a file on disk. The only file written is the
pipeline itself ("save parameters"), and only inside the folders the engine was given.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
import secrets
import struct
from http.cookies import SimpleCookie
from importlib import resources
from typing import Any
from urllib.parse import parse_qs

from .engine import Engine

STATIC = {"index.html": "text/html", "style.css": "text/css", "app.js": "text/javascript",
          "graph.js": "text/javascript", "viewer.js": "text/javascript", "controls.js": "text/javascript"}


def static_files() -> dict[str, bytes]:
    root = resources.files(__package__).joinpath("static")
    return {name: root.joinpath(name).read_bytes() for name in STATIC}


class Guard:
    """ASGI middleware: token, Host and Origin checks on every request and websocket."""

    def __init__(self, app: Any, token: str, hosts: set[str] | None):
        self.app, self.token, self.hosts = app, token, hosts
        self.cookie = ""

    def allowed(self, scope: dict[str, Any]) -> bool:
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope.get("headers", [])}
        host = headers.get("host")
        if host is None or (self.hosts is not None and host not in self.hosts):
            return False  # None: listening on a wider address, reached by whatever name the network gives it
        origin = headers.get("origin")
        if origin is not None and origin != f"http://{host}":
            return False
        query = parse_qs(scope.get("query_string", b"").decode("latin-1"))
        given = query.get("token", [""])[0]
        if not given and "cookie" in headers:
            jar: SimpleCookie = SimpleCookie()
            try:
                jar.load(headers["cookie"])
            except Exception:  # noqa: BLE001 - a malformed cookie header is no token
                return False
            morsel = jar.get(self.cookie)
            given = morsel.value if morsel is not None else ""
        return bool(given) and secrets.compare_digest(given.encode(), self.token.encode())

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] in ("http", "websocket") and not self.allowed(scope):
            if scope["type"] == "websocket":
                await send({"type": "websocket.close", "code": 1008})  # before accept: uvicorn answers 403
                return
            await send({"type": "http.response.start", "status": 403,
                        "headers": [(b"content-type", b"text/plain; charset=utf-8")]})
            await send({"type": "http.response.body", "body": b"403: this server needs its token\n"})
            return
        await self.app(scope, receive, send)


def pack_image(header: dict[str, Any], pixels: bytes) -> bytes:
    """A binary websocket message: 4 bytes of header length (little endian), the JSON header, the view's PNG
    (nothing where the header says `reuse`: the page holds that picture)."""
    head = json.dumps(header).encode()
    return struct.pack("<I", len(head)) + head + pixels


def make_app(engine: Engine, token: str, port: int, hosts: set[str] | None) -> Any:
    from starlette.applications import Starlette
    from starlette.responses import JSONResponse, Response
    from starlette.routing import Route, WebSocketRoute
    from starlette.websockets import WebSocket, WebSocketDisconnect

    files = static_files()
    cookie = f"sketchgraph_token_{port}"
    ids = itertools.count(1)

    async def index(request: Any) -> Response:
        resp = Response(files["index.html"], media_type="text/html")
        resp.set_cookie(cookie, token, httponly=True, samesite="strict")
        resp.headers["cache-control"] = "no-store"
        resp.headers["referrer-policy"] = "no-referrer"
        return resp

    async def static(request: Any) -> Response:
        name = request.path_params["name"]
        if name not in files or name == "index.html":
            return Response("not found\n", status_code=404, media_type="text/plain")
        return Response(files[name], media_type=STATIC[name], headers={"cache-control": "no-store"})

    async def state(request: Any) -> Response:
        return JSONResponse(engine.state())

    async def socket(ws: WebSocket) -> None:
        await ws.accept()
        loop = asyncio.get_running_loop()
        queue: asyncio.Queue[Any] = asyncio.Queue()
        cid = next(ids)

        def send(message: Any) -> None:  # called on the render thread
            loop.call_soon_threadsafe(queue.put_nowait, message)

        async def writer() -> None:
            while True:
                msg = await queue.get()
                if msg is None:
                    return
                if isinstance(msg, tuple):
                    await ws.send_bytes(pack_image(*msg))
                else:
                    await ws.send_text(json.dumps(msg))

        task = asyncio.create_task(writer())
        engine.add_client(cid, send)
        send(engine.state())
        try:
            while True:
                text = await ws.receive_text()
                try:
                    msg = json.loads(text)
                except ValueError:
                    continue
                if isinstance(msg, dict):
                    with contextlib.suppress(ValueError, TypeError, OverflowError):  # a malformed message
                        engine.submit(cid, msg)
        except (WebSocketDisconnect, RuntimeError):
            pass
        finally:
            engine.remove_client(cid)
            queue.put_nowait(None)
            task.cancel()

    async def favicon(request: Any) -> Response:
        return Response(status_code=204)

    app = Starlette(routes=[Route("/", index), Route("/static/{name}", static), Route("/api/state", state),
                            Route("/favicon.ico", favicon),
                            WebSocketRoute("/ws", socket)])
    guard = Guard(app, token, hosts)
    guard.cookie = cookie
    return guard


def new_token() -> str:
    return secrets.token_urlsafe(24)
