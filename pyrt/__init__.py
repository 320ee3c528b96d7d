"""pyrt: a Python renderer whose ray queries run on Embree and whose shading is vectorized NumPy.

Public API::

    import pyrt
    scene = pyrt.Scene(pyrt.Camera(position=(0, 1, 4), target=(0, 0.5, 0), fov=40, width=640, height=480))
    scene.add_sphere((0, 0.5, 0), 0.5, pyrt.Lambert(albedo=(0.8, 0.2, 0.2)))
    scene.add_light(pyrt.PointLight((2, 3, 2), intensity=20.0))
    image = pyrt.render(scene, spp=4)          # (H, W, 3) float32 linear radiance
    pyrt.write_exr("out.exr", image); pyrt.write_png("out.png", image, tonemap="reinhard")
"""
from pyrt.core.errors import Error, RenderError
from pyrt.core.camera import Camera, CameraError
from pyrt.geometry.mesh_data import GeometryError
from pyrt.integrators import PreparedScene, RenderStats
from pyrt.render import RenderResult, render, render_full
from pyrt.render import Execution, Glossy, Output, Sampling, Whitted
from pyrt.render.warmup import compile_kernels
from pyrt.lights import DirectionalLight, Light, LightError, PointLight, SpotLight
from pyrt.lights import GoniometricLight, IESLight, ProjectorLight
from pyrt.materials import Material, MaterialError, REGISTRY as MATERIALS, Lambert, BlinnPhong, Mirror, Glass, register
from pyrt.materials import (BlinnPhongClassic, CookTorrance, MetallicRoughness, Phong, PhongClassic,  # material library
                        Ward, RoughDielectric, Clearcoat, GltfPBR, Unlit, Sheen)
from pyrt.materials import Conductor, LearnOpenGLPBR, OrenNayar
from pyrt.scene import Scene, SceneError, transform_matrix
from pyrt.lights import (ConstantEnvironment, CubeMapEnvironment, EnvironmentLight, EnvironmentMapError,
                          LatLongEnvironment, procedural_sky, set_environment)
from pyrt.lights import AreaEmitter, DiskLight, RectLight, SphereLight
from pyrt.lights import EmissiveMeshLight
from pyrt.core.image_io import atomic_write, read_exr, write_exr, write_png, tonemap_to_display
from pyrt.core.display import Picture, show
from pyrt.io.scene_file import SceneFileError, load_scene
from pyrt.io.scene_file import load_dict
from pyrt.io.assets import AssetError, load_asset
from pyrt.textures import (CheckerTexture, ConstantTexture, FbmTexture, ImageTexture, NoiseTexture, NormalMap,
                       PerlinTexture, Texture, TextureError, VoronoiTexture, perturb_normal)

__all__ = [
    "Error", "Camera", "CameraError", "GeometryError", "RenderResult", "RenderStats", "PreparedScene", "render", "render_full", "compile_kernels",
    "Whitted", "Glossy", "Sampling", "Output", "Execution", "Picture", "show",
    "DirectionalLight", "Light", "LightError", "PointLight", "SpotLight", "ProjectorLight", "GoniometricLight", "IESLight", "Material", "MaterialError", "MATERIALS",
    "Lambert", "BlinnPhong", "Mirror", "Glass", "register", "Phong", "PhongClassic", "BlinnPhongClassic", "Ward", "RoughDielectric", "Clearcoat", "GltfPBR", "Unlit", "Sheen",
    "CookTorrance", "MetallicRoughness", "Conductor", "LearnOpenGLPBR", "OrenNayar", "Scene", "SceneError", "transform_matrix",
    "atomic_write", "read_exr", "write_exr", "write_png", "tonemap_to_display", "SceneFileError", "load_scene",
    "ConstantEnvironment", "CubeMapEnvironment", "EnvironmentLight", "EnvironmentMapError", "LatLongEnvironment",
    "procedural_sky", "set_environment", "AreaEmitter", "DiskLight", "RectLight", "SphereLight",
    "EmissiveMeshLight",
    "Texture", "TextureError", "ConstantTexture", "ImageTexture", "CheckerTexture", "NoiseTexture", "PerlinTexture",
    "FbmTexture", "VoronoiTexture", "NormalMap", "perturb_normal",
    "load_dict", "load_asset", "AssetError", "RenderError",
]
__version__ = "0.1.0"
