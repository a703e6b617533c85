# SPDX-License-Identifier: Apache-2.0
"""What a notebook shows (issue 26.6): HTML for ``Report`` and ``DiffResult``, and
``Scene.with_material`` to change one material."""

from __future__ import annotations

import html
import re

import numpy as np
import pytest

import phongscene as ps
from support.paths import EXAMPLES


def test_a_report_shows_its_verdict_and_its_facts_as_html():
    a = np.zeros((4, 5, 3), np.float32)
    b = a.copy()
    b[1, 2] = 0.5
    failing = ps.compare(a, b)._repr_html_()
    assert "<b style='color:#cf222e'>FAIL</b>: 1 of 20 pixels fail" in failing
    assert html.escape(ps.compare(a, b).summary().splitlines()[1].strip()) in failing
    assert ">PASS</b>: 0 of 20 pixels fail" in ps.compare(a, a)._repr_html_()


@pytest.mark.povray
def test_a_diff_result_shows_both_images_and_the_report(tmp_path):
    result = ps.diff(EXAMPLES / "seed_lobe.usda", width=24, height=18)
    page = result._repr_html_()
    assert page.startswith("<div class='phongscene-diff'><b>PASS</b>: 24 x 18, mapping exact")
    assert len(re.findall(r"<img src='data:image/png;base64,", page)) == 2
    assert result.report._repr_html_() in page


def test_with_material_changes_every_object_bound_to_it_and_nothing_else():
    scene = ps.load_usd(EXAMPLES / "seed_lobe.usda")
    changed = scene.with_material("/World/Looks/Exponent2", ks=0.5, diffuse_color=(1, 0, 0))
    by_source = {o.source: o.material for o in (*changed.spheres, *changed.meshes)}
    before = {o.source: o.material for o in (*scene.spheres, *scene.meshes)}
    (path,) = [p for p, m in before.items() if m.source.startswith("/World/Looks/Exponent2/")]
    assert by_source[path].ks == 0.5 and by_source[path].diffuse_color == (1, 0, 0)
    assert by_source[path].exponent == before[path].exponent  # the rest kept
    assert all(by_source[p] == before[p] for p in before if p != path)
    # By the object's path: that object only; by the shader's own path: the same as the material's.
    ground = next(m for m in (*scene.meshes,)).source
    assert changed.with_material(ground, kd=0.1).meshes[0].material.kd == 0.1
    by_shader = scene.with_material(before[path].source, ks=0.5, diffuse_color=(1, 0, 0))
    assert [o.material for o in by_shader.spheres] == [o.material for o in changed.spheres]
    image = ps.render(changed, width=24, explain=False)
    assert not np.array_equal(image, ps.render(scene, width=24, explain=False))


def test_with_material_names_what_it_cannot_change():
    scene = ps.load_usd(EXAMPLES / "seed_lobe.usda")
    with pytest.raises(TypeError, match="'kss' is not a PhongMaterial field \\(did you mean 'ks'\\?\\)"):
        scene.with_material("/World/Looks/Exponent2", kss=0.5)
    with pytest.raises(KeyError, match="no material or object at '/World/Looks/Nope'; the materials: /World/Looks/"):
        scene.with_material("/World/Looks/Nope", ks=0.5)
    with pytest.raises(ps.SceneError, match="ks"):
        ps.render(scene.with_material("/World/Looks/Exponent2", ks=2.0), width=8)  # validated when it renders
