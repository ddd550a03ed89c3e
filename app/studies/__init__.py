"""Studies: one request that fans out into many ordinary jobs (a list or grid of overrides
applied to one base spec) and an aggregate table computed from the stored job results.
Science-free: this package only expands specs and reduces summaries."""
