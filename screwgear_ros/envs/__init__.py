"""Reinforcement-learning environments over the in-process simulation: the Gymnasium
environment ``ScrewgearTable-v0`` (:mod:`.table_env`)."""
