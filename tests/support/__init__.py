# SPDX-License-Identifier: Apache-2.0
"""What the tests share, imported the same way from every folder: ``from support import oracle``
(or ``from support.paths import REPO``). ``tests/`` is on ``sys.path`` through pytest's
``pythonpath`` setting (pyproject.toml), so no test touches ``sys.path`` itself.

- ``paths``: the repository, its examples, the test scenes and golden files, the shared assets.
- ``oracle``: the independent numpy renderer both backends are tested against.
- ``calibration``: small scenes with one idea each, built with the scene model.
- ``fuzz``: the fuzzing budget and seed.
- ``preview_reference``: an independent UsdPreviewSurface BRDF (also a script)."""
