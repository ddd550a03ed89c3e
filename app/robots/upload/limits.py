"""The caps an uploaded robot must stay within (docs/robots.md lists them with the reason
for each). Checked before parsing (bytes, files), while parsing (depth, elements, the
size attributes that make MuJoCo allocate) and after compiling (the model's sizes)."""

from __future__ import annotations

import dataclasses

MiB = 1024 * 1024


@dataclasses.dataclass(frozen=True)
class Limits:
    # the upload
    max_upload_bytes: int = 32 * MiB  # everything together (the request body, the zip)
    max_files: int = 256
    max_file_bytes: int = 16 * MiB
    max_xml_bytes: int = 2 * MiB  # one MJCF file
    max_zip_ratio: int = 100  # uncompressed / compressed bytes of a zip entry
    max_name_length: int = 255
    # parsing
    max_depth: int = 64
    max_elements: int = 20_000  # after includes are inlined
    max_include_depth: int = 4
    max_replicate: int = 64  # product of nested <replicate count>
    max_texture_pixels: int = 4096 * 4096  # builtin width*height, or a PNG's header
    max_hfield_samples: int = 1024 * 1024  # nrow*ncol
    max_numeric_size: int = 10_000
    max_user_size: int = 10_000  # nuserdata, nuser_* and friends
    max_keys: int = 100
    max_arena_bytes: int = 256 * MiB  # <size memory>, and the compiled model's narena
    max_render_size: int = 8192  # visual: offwidth, offheight, shadowsize
    # the compile (a separate process)
    compile_memory_bytes: int = 1024 * MiB  # address space beyond what python + mujoco map at start
    compile_cpu_s: int = 20
    compile_wall_s: float = 40.0
    # the compiled model
    max_bodies: int = 256
    max_joints: int = 256
    max_geoms: int = 2048
    max_actuators: int = 256
    max_mesh_vertices: int = 500_000
    max_mesh_faces: int = 1_000_000
    max_hfield_data: int = 1024 * 1024
    max_texture_bytes: int = 64 * MiB
    max_extent_m: float = 1000.0
    min_timestep: float = 1e-4
    max_timestep: float = 0.05
    max_iterations: int = 1000


LIMITS = Limits()
