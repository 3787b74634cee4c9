"""Training the learning agents of modquad_gym (the repository's ``agents/``, not part of the
wheel): expert labels and behaviour cloning (:mod:`.imitation`), the PPO recipe and publishing a
run (:mod:`.training`). ``train.py`` is the entry point; see ``agents/README.md`` for what lives
here and what stays in the package.
"""
