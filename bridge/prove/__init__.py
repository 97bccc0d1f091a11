"""The proof harness, apart from the method it proves: generated worlds with one effect concealed by a physical
mechanism, diagnosed blind, and the figures (`bridge prove`, benchmarks/prove_benchmark.py).

scenes.py     the proof's scenes, the world model each recording is given, the pushes
generate.py   recordings with an effect concealed (the effects' own `conceal`), truth.json beside them
proof.py      cases, running the diagnosis on them, checking verdicts against the truth, the summary
"""
