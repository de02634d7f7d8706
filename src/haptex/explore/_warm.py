"""Imported once by the explorer's forkserver (:func:`haptex.explore.app._context`): the
library's imports and one-time set-up (pint's registry, the default views) done before any
session's worker process is forked from it."""

from . import app, model  # noqa: F401 (app: the workers' entry points)

model.views(model.build(model.Settings()))
