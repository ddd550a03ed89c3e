"""The adaptation's evaluation (issue 44): `gaitmend reproduce adapt [--write-docs]`
(``evaluation``) and the docs/adapt.md section rendered from its JSON (``report``).
Registered beside the cross-kind reproductions (app/cli/local.py, app/results/docs_gen.py);
no runtime module of app/adapt imports this package."""
