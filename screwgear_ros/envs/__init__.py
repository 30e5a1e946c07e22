"""Gymnasium environments of the table (``pip install screwgear_ros[gym]``).

Importing this package registers them, so ``gymnasium.make('screwgear_ros.envs:ScrewgearTable-v0')``
works in a fresh interpreter (:mod:`screwgear_ros.envs.table_env`).
"""

from .table_env import ENV_ID, ScrewgearTableEnv

__all__ = ['ENV_ID', 'ScrewgearTableEnv']
