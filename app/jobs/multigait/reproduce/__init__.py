"""The multigait kind's reproductions, benches and doc generators: never imported by the job's
runtime (tests/test_layers.py checks); the kind reaches them through its ``experiments`` and
``bench`` hooks (``Deferred(".reproduce....")``)."""
