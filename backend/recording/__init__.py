"""Recordings robotics tools read: MCAP files as rosbag2 writes them (backend/recording/mcap_recorder.py),
and reading recordings back as frames for `nutty play` (backend/recording/playback.py)."""
