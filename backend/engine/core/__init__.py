"""The compiled program core: a program's compiled blocks run as a few kernel calls over one arena.

See `backend.engine.core.program` (how a program becomes op tables and segments) and
`backend.engine.core.vm` (the kernel).
"""
