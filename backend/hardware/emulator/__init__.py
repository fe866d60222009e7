"""Servo bus emulators for development and tests without a robot: a pseudo-terminal that answers a
serial protocol as real servos would (written from the protocols' published documents, independently
of the drivers' SDKs), and a PCA9685 register model on a stand-in I2C bus. `nutty hardware emulate`
runs one and prints the port to give hardware.yaml."""
