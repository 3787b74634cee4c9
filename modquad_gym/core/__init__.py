"""Infrastructure every layer may use: optional imports (:mod:`.extras`), input checks
(:mod:`.validation`), command-line option types (:mod:`.options`), safe output files
(:mod:`.outputs`) and the Ray engine for work that outgrows one process (:mod:`.distributed`).

Nothing here imports another part of the package, and importing it stays light (Ray loads only
when an engine starts).
"""
