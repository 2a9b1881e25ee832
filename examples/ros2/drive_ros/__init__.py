"""drive_ros: the DRIVE protocol, a path follower and a prediction display as ROS 2 nodes,
on the `drive` Python package (pip install drive-ugv). Each node's logic is a plain class
without ROS imports (protocol_logic, track_logic, predict_logic), tested with fake
messages; the *_node modules wire them to topics, parameters and timers."""
