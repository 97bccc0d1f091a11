"""Diagnosis: locate where simulation and recordings differ, name the missing physics from a catalog of effects,
model it and prove the method on recordings with concealed effects (docs/diagnosis.md)."""
