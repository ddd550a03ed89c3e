"""`gaitmend reproduce adapt`'s options, where its JSON lives and the command that writes it:
read by the registration (experiment.py) and by the work (evaluation.py)."""

from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel, Field

JSON = Path("docs/adapt_evaluation.json")
COMMAND = "gaitmend reproduce adapt --write-docs"
ANT_JSON = Path("docs/adapt_evaluation_ant.json")  # the uploaded robot's evaluation (the Gymnasium ant)
ANT_COMMAND = "gaitmend reproduce adapt-ant --write-docs"


class Params(BaseModel):
    robot: str = Field("jethexa", pattern="^(jethexa|gym_ant)$", description=(
        "the robot: jethexa (the built-in hexapod) or gym_ant (the Gymnasium ant, uploaded as a user's robot is)"))
    realities: int = Field(30, ge=1, le=1000, description="realities to have in the file (those there are kept)")
    seed: int = Field(0, ge=0, le=2**31 - 1, description="reality k is drawn from (seed, k)")
    json_out: Path = Field(JSON, description="the evaluation's JSON (appended reality by reality)")
    maps_dir: Path = Field(Path("reproduced/adapt_maps"), description="where the built maps are cached")
    quick: bool = Field(False, description="tiny maps and trials (the tests' size), not the published budget")
    de_only: bool = Field(False, description=(
        "run only the recovery kind's DE arm on the realities the file holds (needs no maps)"))
    stop_at: float = Field(0.0, ge=0.0, description="unix time after which no new reality is started (0: none)")


class AntParams(Params):
    robot: str = Field("gym_ant", pattern="^(jethexa|gym_ant)$", description="the robot (gym_ant: the Gymnasium ant, "
                                                                            "uploaded)")
    json_out: Path = Field(ANT_JSON, description="the evaluation's JSON (appended reality by reality)")
