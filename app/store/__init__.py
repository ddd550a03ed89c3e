"""The jobs database: SQLAlchemy models, engine and session scope, repository functions."""

from app.store import robot_models  # noqa: F401  (the robots table joins the one metadata)
from app.store import adaptation_models  # noqa: F401,E402  (the adaptation tables, issue 44)
