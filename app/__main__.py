"""`python -m app` runs the gaitmend CLI."""

from app.cli import main

main()
