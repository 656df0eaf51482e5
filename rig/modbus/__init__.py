"""The Modbus link shared by every device the rig drives (turntable, chamber): link URLs, RTU at line speed,
one channel with bounded retries, backoff and reconnect, and the link's errors."""
