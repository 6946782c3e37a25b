"""pcrp_ros: the thin ROS 2 wrapper around pcrp_core (node, PointCloud2 conversion, rosbags)."""
