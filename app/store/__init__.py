"""The jobs database: SQLAlchemy models, engine and session scope, repository functions."""
