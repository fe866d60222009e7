"""ROS 2 and its tools: the live link (`nutty serve --ros2`, `nutty bridge --ros2`), what a frame looks
like to robotics tools (view.py), and ROS 2 messages as CDR without ROS (cdr.py, for MCAP and Foxglove).

rclpy is imported only where a live link is made (node.py): the `[ros2]` extra installs ROS 2 Kilted's
wheels (no ROS installation, no setup.bash). docs/ros2.md says how RViz, ros2_control, rosbag2 and
Foxglove meet the engine.
"""
