"""The example shipped with fabpanel: the barrel vault that ``fabpanel demo`` runs.

``barrel-vault.toml`` (the job) and ``barrel-vault.step`` (its surface, next to it) are package
data; :mod:`fabpanel.examples.barrel_vault` regenerates the STEP. The larger example shapes
(test and benchmark fixtures) stay in the checkout's top-level ``examples/`` and are not shipped.
"""
