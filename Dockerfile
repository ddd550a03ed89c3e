# One image for the API and the workers (docker-compose.yml picks the command).
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 PYTHONUNBUFFERED=1 PIP_NO_CACHE_DIR=1

WORKDIR /src
COPY pyproject.toml setup.py README.md LICENSE alembic.ini ./
COPY app app
COPY workers workers
COPY migrations migrations
COPY web web
# Editable, so `gaitmend db upgrade` finds migrations/ beside the app package.
RUN pip install -e .

RUN useradd --create-home --uid 1000 gaitmend && mkdir -p /data && chown gaitmend /data
USER gaitmend
WORKDIR /data
ENV GAITMEND_DATA_DIR=/data
VOLUME /data
EXPOSE 8000
CMD ["gaitmend", "serve", "--host", "0.0.0.0", "--port", "8000"]
