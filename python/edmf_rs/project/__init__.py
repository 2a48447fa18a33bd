"""Project files: an identification described in TOML, run end to end.

``schema`` reads and checks the project file, ``inputs`` the measurements,
``sources`` turns uncertainty sources into a combined uncertainty,
``sampling`` draws the model instances, ``run`` evaluates the model and
falsifies, ``diagnostics`` and ``prognosis`` explain and use the candidates,
``result`` writes the outputs and ``report`` renders them. Depends on the
engine; the engine does not depend on it.
"""

from .command import run_cli
from .prognosis import Prognosis, predict
from .run import Project
from .schema import ProjectError

__all__ = ["Prognosis", "Project", "ProjectError", "predict", "run_cli"]
