"""Diagnosis: locate where simulation and recordings differ, name the missing physics from a catalog of effects,
model it, and check the model on recordings it was not fitted to (docs/diagnosis.md).

runs.py        models run on prepared recordings (through bridge.rollout), residuals against the observations
residuals.py   observed series with their noise estimated from the data; the robot's force
locate.py      where and when simulation and recordings part, after which contact, in which direction
effects/       the catalog: one effect per file, each a bundle of parameter kinds with its signature and seeds
search.py      fits in normalised coordinates (bridge.optim), the criteria that compare fitted models
identify.py    the recipe: ordinary parameters, screening, full fits, the verdict
report.py      diagnosis.json (schema beside it), report.md, plots
pipeline.py    `bridge diagnose` end to end; the scene file

The proof that it works is `bridge.prove`.
"""
