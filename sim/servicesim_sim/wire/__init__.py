"""Messages serialised by hand: the CDR bytes of the simulator's high-rate messages.

Design intent: a message whose layout is fixed once its strings are known is written once as
a template and only its numbers packed in each time, which costs a fraction of building an
rclpy message; each module here writes exactly the bytes rclpy would (tests compare them).
"""
