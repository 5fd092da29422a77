"""Run the command line as ``python -m lanefinder``."""

from ._entry import main

main()
