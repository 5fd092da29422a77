"""Run the command line as ``python -m lanefinder``."""

from .cli import main

main()
