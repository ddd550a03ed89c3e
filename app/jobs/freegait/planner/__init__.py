"""The free-crab gait planner: geometry, parameters, route, foothold search and the walk (paper 004)."""
