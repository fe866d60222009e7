"""Animation Programs: the JSON graph format, its validator/compiler and live swapping."""
