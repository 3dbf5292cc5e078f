"""The limits of a timeline, shared by the scene's animation (default frame ranges) and the outputs (frame
ranges given on the command line). No imports: the command line reads these before anything heavy loads."""

MAX_FRAMES = 1_000_000
"""Most frames one --frames range may name."""
MAX_FRAME = 2**31 - 1
"""Frame numbers are stored as 32-bit integers (shader uniforms, seeds): |frame| at most this."""

ANIMATION_ENDS = ("hold", "loop")
"""What a clip shorter than the film does after its last key: hold its last pose, or loop from its start."""
