"""Sub-commands of `nutty`; each module defines `register(subparsers)`."""
