"""The files whose code decides a recovery run's numbers (the ledgers' code version,
app/jobs/ledger.py): each reproduction adds its own search module and optimiser. The
JetHexa's entry (its nominal stance and gait: the baseline, the IK stance) is one of them.
This module is in none of the lists, so editing it changes no ledger's version."""

BASE = ("app/jobs/recovery/evaluate.py", "app/jobs/recovery/closedloop.py", "app/jobs/recovery/gait_controller.py",
        "app/jobs/recovery/cases.py", "app/jobs/recovery/robust.py", "app/jobs/recovery/metrics.py",
        "app/jobs/recovery/trajectory.py", "app/jobs/recovery/sequences.py", "app/jobs/recovery/spec.py",
        "app/jobs/recovery/run.py", "app/jobs/loop.py", "app/robots/hexapod/__init__.py",
        "app/robots/hexapod/entry.py", "app/robots/ik.py", "app/sim/perturb.py", "app/sim/batch.py")
