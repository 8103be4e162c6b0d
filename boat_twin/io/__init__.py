"""Formats only: ROS 2 messages (rosbags typestore), rosbag2 / MCAP bags, MAVLink logs, and the Trial every
analysis reads. Its modules are the API (imported on use, so that importing the package stays cheap):
``messages`` (topics, builders, CDR), ``bags`` (write_bag, read_trial), ``trial`` (Trial, build_trial),
``mavlink`` (MAVLink logs), ``roles`` (the streams' role names), ``sources`` (read_trial_file: any trial
file), ``log_messages`` (a MAVLink log as the package's messages)."""

__all__ = ["bags", "log_messages", "mavlink", "messages", "roles", "sources", "trial"]
