"""rclpy adapters: the only modules that import rclpy."""
