# SPDX-License-Identifier: Apache-2.0
"""Memory of texture-heavy scenes (issue 28): peak RSS and wall time of whole ``phongscene
render`` (native) and ``phongscene diff`` processes on K quads, each with its own SIZE² 8-bit
sRGB PNG as UsdPreviewSurface's diffuseColor (noise, so that no codec or cache shortens it),
160 wide, 2 threads. Each texture is 12·SIZE² bytes in the model (float32 RGB): 48 MiB at 2048.
Peak RSS from ``/usr/bin/time -v`` (``instances.timed``: the largest process of the tree).

    .venv/bin/python benchmarks/texture_memory.py [--textures 8] [--size 2048]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from instances import REPO, timed

PHONGSCENE = str(REPO / ".venv" / "bin" / "phongscene")
WIDTH = 160
THREADS = 2
QUADS_PER_ROW = 4


def write_scene(path: Path, count: int, size: int) -> None:
    """``count`` unit quads in rows of QUADS_PER_ROW, each with its own noise texture beside
    ``path``."""
    import OpenImageIO as oiio
    from pxr import Sdf, Usd, UsdGeom, UsdShade

    rng = np.random.default_rng(1)
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    for i in range(count):
        image = path.parent / f"texture{i}.png"
        out = oiio.ImageOutput.create(str(image))
        out.open(str(image), oiio.ImageSpec(size, size, 3, "uint8"))
        out.write_image(rng.integers(0, 256, size=(size, size, 3), dtype=np.uint8))
        out.close()
        x, y = (i % QUADS_PER_ROW) * 1.1, (i // QUADS_PER_ROW) * 1.1
        mesh = UsdGeom.Mesh.Define(stage, f"/World/quad{i}")
        mesh.CreatePointsAttr([(x, y, 0), (x + 1, y, 0), (x + 1, y + 1, 0), (x, y + 1, 0)])
        mesh.CreateFaceVertexCountsAttr([4])
        mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
        mesh.CreateSubdivisionSchemeAttr("none")
        st = UsdGeom.PrimvarsAPI(mesh).CreatePrimvar("st", Sdf.ValueTypeNames.TexCoord2fArray, UsdGeom.Tokens.vertex)
        st.Set([(0, 0), (1, 0), (1, 1), (0, 1)])
        material = UsdShade.Material.Define(stage, f"/World/material{i}")
        surface = UsdShade.Shader.Define(stage, f"/World/material{i}/surface")
        surface.CreateIdAttr("UsdPreviewSurface")
        texture = UsdShade.Shader.Define(stage, f"/World/material{i}/texture")
        texture.CreateIdAttr("UsdUVTexture")
        texture.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(image.name)
        reader = UsdShade.Shader.Define(stage, f"/World/material{i}/st")
        reader.CreateIdAttr("UsdPrimvarReader_float2")
        reader.CreateInput("varname", Sdf.ValueTypeNames.Token).Set("st")
        texture.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
        texture.CreateOutput("rgb", Sdf.ValueTypeNames.Float3)
        diffuse = surface.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f)
        diffuse.ConnectToSource(texture.ConnectableAPI(), "rgb")
        material.CreateSurfaceOutput().ConnectToSource(surface.ConnectableAPI(), "surface")
        UsdShade.MaterialBindingAPI.Apply(mesh.GetPrim()).Bind(material)
    stage.GetRootLayer().Save()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--textures", type=int, default=8)
    parser.add_argument("--size", type=int, default=2048)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        scene = tmp / "textured.usda"
        write_scene(scene, args.textures, args.size)
        model_mib = args.textures * 12 * args.size**2 / 2**20
        print(f"{args.textures} textures of {args.size}², {model_mib:.0f} MiB of float32 texels in the model")
        common = [str(scene), "--width", str(WIDTH), "--threads", str(THREADS)]
        commands = {
            "render (native)": [PHONGSCENE, "render", *common, "-o", str(tmp / "native.png"), "--backend", "native"],
            "diff": [PHONGSCENE, "diff", *common, "-o", str(tmp / "report")],
        }
        for name, command in commands.items():
            rss, wall, _ = timed(command)
            print(f"{name:<16}  peak RSS {rss:6.0f} MiB  wall {wall:5.2f} s", flush=True)


if __name__ == "__main__":
    main()
