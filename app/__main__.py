"""`python -m app` runs the gaitmend CLI (the module app.cli must be imported once only,
so that the service commands registered on it by app.service_cli are there)."""

from app.cli import main

main()
