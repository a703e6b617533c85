# SPDX-License-Identifier: Apache-2.0
"""MkDocs hook: figures that live beside the scripts that make them (benchmarks/results/), published
at a path inside the site, so a page links to them as to any image of its own and the benchmark
scripts keep writing where they always did. A missing figure fails the build."""

from __future__ import annotations

from pathlib import Path

from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File

# site path (as a page links it, relative to docs/) -> the file, relative to the repository
FIGURES = {
    "validation/speed_vs_error.png": "benchmarks/results/speed_vs_error.png",
}


def on_files(files, config):
    repository = Path(config["config_file_path"]).parent
    for site_path, source in FIGURES.items():
        path = repository / source
        if not path.is_file():
            raise PluginError(f"docs/hooks/figures.py: {source} is missing (it is shown as {site_path})")
        files.append(File.generated(config, site_path, abs_src_path=str(path)))
    return files
