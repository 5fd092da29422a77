"""lanefinder: lane finding on a car's forward camera."""
__version__ = "0.1.0"
