"""`python -m attenfit` runs the CLI."""

from .cli import main

raise SystemExit(main())
