"""Adaptation on the robot (issue 44): a lab runs a proposed gait, posts what it measured,
and gets the next gait, until the robot walks.

The methods choose among the elites of one or more gait repertoires (maps built before any
damage, app/jobs/repertoire). Each is a pure function of the map(s) and the trials so far
(``Trial``), so a session's whole state is its list of trials: a restart of the service
loses nothing, and the same trials give the same next proposal on any machine.

- ``model``: the Gaussian process over a map's behaviour space whose prior mean is the
  map (scikit-learn's GaussianProcessRegressor on the residual, fixed hyperparameters).
- ``methods``: Intelligent Trial and Error as published (Cully et al., Nature 2015) and
  gaitmend's multi-prior variant, behind one ``propose`` / ``decide`` interface.
"""
