"""The Nutty engine: embodiment, animation frames, blocks, the APU and the fixed-rate runtime."""
