"""The HTTP and WebSocket routes of the server, one router per concern (assembled by backend.api).

robot (embodiment, URDF), program (blocks, schemas, the running program), library (programs, clips,
postures on disk), commands (exposed inputs, commands), status (status, Pre-Viz info and proxy),
sockets (/ws/control, /ws/telemetry, /ws/frames), analysis (the trajectory-helper and the ghost),
clip_editing (the clip editor's Pre-Viz preview pose and recorded takes). Routes reach the server's state through
`backend.routes.state` (the app's Hub), and read JSON bodies through `backend.routes.json_body`.
"""
