"""What a worker and `gaitmend serve` run: the runner, dispatch, the broker, housekeeping."""
