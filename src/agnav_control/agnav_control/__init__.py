"""agnav steering: straight-line guidance, controllers, engage and watchdog."""
