"""`python -m attenfit` runs the CLI."""

from .cli import run

run()
