"""The SIEs of the bundled object database. Reference them from type YAML as ``sies.<module>:<Class>``."""
