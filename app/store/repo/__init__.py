"""The store's repository: every read and write of the service goes through here, each in
the caller's short transaction (app/store/db.py ``session_scope``). One module a concern:

- ``jobs``: submission, reads, history and checkpoints, the user's actions;
- ``listing``: the jobs list and its cursor;
- ``leases``: the lease and fencing protocol a worker runs a job under, and the reaper
  (the protocol is written there, once);
- ``retention``: what housekeeping removes or re-sends;
- ``tokens``: API tokens; ``workers``: the workers seen;
- ``state``: the job's states and the moves between them, shared by the above;
- ``adaptations``: adaptation sessions and their trials (app/adapt/session.py).

Callers use ``repo.<name>``; the names below are the public ones of each module."""

from __future__ import annotations

from app.store.repo.jobs import (  # noqa: F401
    NotFound, Conflict, QueueFull, new_job_id, find_by_idempotency_key, count_queued, lock_owner, submit_job,
    create_job, mark_dispatched, MIN_PREFIX, get_job, history, load_checkpoint, checkpoint_saves,
    request_cancel, retry, delete_job,
)
from app.store.repo.listing import (  # noqa: F401
    MAX_SEQ, CURSOR_PATTERN, encode_cursor, decode_cursor, list_jobs,
)
from app.store.repo.leases import (  # noqa: F401
    Claim, claim, heartbeat, record_progress, save_checkpoint, cancel_requested, job_flags, mark_interrupted,
    interrupt_workers, release, finish, finished_as, reap, undispatch_before, running_count, waiting,
    stale_dispatched,
)
from app.store.repo.retention import (  # noqa: F401
    expired_bundles, forget_bundles, running_ids, drop_checkpoints, undelivered,
)
from app.store.repo.tokens import (  # noqa: F401
    hash_token, create_token, resolve_token, resolve_token_id, token_owner, list_tokens, revoke_token,
    token_count,
)
from app.store.repo.workers import (  # noqa: F401
    worker_seen, worker_gone, idle_slots, workers_seen,
)
from app.store.repo.state import (  # noqa: F401
    lost_reason,
)
from app.store.repo.adaptations import (  # noqa: F401
    Refused, create_adaptation, get_adaptation, list_adaptations, trial_rows, post_trial, adaptation_json,
    trials_json, proposal_bundle, session_state,
)
