// loomlab-sim renderer: single-channel luminance, no lighting.
//
// Coordinates: camera-relative world frame (world axes, z up, camera at the origin) so that f32 stays
// precise far from the world origin. Depth: reversed-Z with an infinite far plane (clear 0, GREATER).
// Textures are procedural and box-filtered over the pixel footprint (see texture.rs).

const TEX_UNIFORM: u32 = 0u;
const TEX_CHECKER: u32 = 1u;
const TEX_SQUARE: u32 = 2u;
const TEX_SINE: u32 = 3u;
const TEX_NOISE: u32 = 4u;
const PI: f32 = 3.14159265358979;

// Texture kind of the surfaces a pipeline draws (set per pipeline; see Pipelines in renderer.rs).
override TEX_KIND: u32 = 0u;

struct Globals {
    view_proj: mat4x4<f32>,
    // camera basis (world axes): optical axis (w: tan(fov/2)), right (w: near plane), up
    cam_fwd: vec4<f32>,
    cam_right: vec4<f32>,
    cam_up: vec4<f32>,
    // change of the viewing ray (unit forward component) per pixel step right (dir_dx) and down (dir_dy)
    dir_dx: vec4<f32>,
    dir_dy: vec4<f32>,
    // xyz: camera world position (for world-anchored ground texture), w: sky luminance
    camera: vec4<f32>,
    // ground texture: a = (dark, light, scale, orientation), b = (phase, binary, enabled, n)
    ground_a: vec4<f32>,
    ground_b: vec4<f32>,
    // x: texture kind, y: seed
    ground_k: vec4<u32>,
};

// A read-only storage buffer rather than a uniform buffer: lavapipe (Mesa 22) specialises shaders on
// uniform-buffer values that feed branches ("inline uniforms") and would recompile every frame as the
// camera moves, costing milliseconds per frame.
@group(0) @binding(0) var<storage, read> g: Globals;

// ---------------------------------------------------------------- textures

fn pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn hash3(x: u32, y: u32, seed: u32) -> f32 {
    let h = pcg(x ^ pcg(y ^ pcg(seed)));
    return f32(h >> 8u) / 16777216.0;
}

// Integral of the ±1 square wave of period 1 (+1 on [0, 0.5)).
fn square_integral(x: f32) -> f32 {
    return 0.5 - abs(fract(x) - 0.5);
}

// Square wave box-filtered over a window of width w (in cycles) centred on x.
fn square_filtered(x: f32, w: f32) -> f32 {
    if (w < 1e-3) {
        return select(-1.0, 1.0, fract(x) < 0.5);
    }
    return (square_integral(x + 0.5 * w) - square_integral(x - 0.5 * w)) / w;
}

// Luminance of texture (kind, a, b) at surface coords uv with screen derivatives duv_dx, duv_dy.
fn texture_value(seed: u32, a: vec4<f32>, b: vec4<f32>, uv: vec2<f32>, duv_dx: vec2<f32>, duv_dy: vec2<f32>) -> f32 {
    let dark = a.x;
    let light = a.y;
    let scale = a.z;
    let mean = 0.5 * (dark + light);
    let amp = 0.5 * (light - dark);
    switch TEX_KIND {
        case TEX_CHECKER: {
            let p = uv / (2.0 * scale);
            let w = (abs(duv_dx) + abs(duv_dy)) / (2.0 * scale);
            let s = square_filtered(p.x, w.x) * square_filtered(p.y, w.y);
            return mean - amp * s;
        }
        case TEX_SQUARE, TEX_SINE: {
            let dir = vec2<f32>(sin(a.w), cos(a.w));
            let x = dot(uv, dir) / scale - b.x;
            let w = (abs(dot(duv_dx, dir)) + abs(dot(duv_dy, dir))) / scale;
            if (TEX_KIND == TEX_SQUARE) {
                return mean + amp * square_filtered(x, w);
            }
            var atten = 1.0;
            if (w >= 1.0) {
                atten = 0.0;
            } else if (w > 1e-3) {
                atten = sin(PI * w) / (PI * w);
            }
            return mean + amp * atten * sin(2.0 * PI * x);
        }
        case TEX_NOISE: {
            let cell = floor(uv / scale);
            let h = hash3(bitcast<u32>(i32(cell.x)), bitcast<u32>(i32(cell.y)), seed);
            var v = dark + (light - dark) * h;
            if (b.y > 0.5) {
                v = select(dark, light, h >= 0.5);
            }
            let w = max(abs(duv_dx.x) + abs(duv_dy.x), abs(duv_dx.y) + abs(duv_dy.y)) / scale;
            return mix(mean, v, min(1.0, 1.0 / max(w, 1e-6)));
        }
        default: {
            return dark;
        }
    }
}

// ---------------------------------------------------------------- background: ground plane and sky

struct BgOut {
    @builtin(position) pos: vec4<f32>,
    // viewing ray with unit component along the optical axis (linear in screen space)
    @location(0) dir: vec3<f32>,
    // The globals the fragment stage reads, passed as flat inputs: llvmpipe loads a storage
    // buffer per pixel (and per lane), a flat input once per triangle.
    @location(1) @interpolate(flat) camera: vec4<f32>,
    @location(2) @interpolate(flat) dir_dx: vec4<f32>,
    @location(3) @interpolate(flat) dir_dy: vec4<f32>,
    @location(4) @interpolate(flat) ground_a: vec4<f32>,
    @location(5) @interpolate(flat) ground_b: vec4<f32>,
    @location(6) @interpolate(flat) ground_k: vec4<u32>,
    @location(7) @interpolate(flat) near: f32,
};

// One triangle covering the screen, read from the mesh vertex buffer (NDC x, y in `pos.xy`).
@vertex
fn vs_background(@location(0) pos: vec3<f32>) -> BgOut {
    var o: BgOut;
    o.pos = vec4<f32>(pos.xy, 0.0, 1.0);
    let tan_half = g.cam_fwd.w;
    o.dir = g.cam_fwd.xyz + tan_half * (pos.x * g.cam_right.xyz + pos.y * g.cam_up.xyz);
    o.camera = g.camera;
    o.dir_dx = g.dir_dx;
    o.dir_dy = g.dir_dy;
    o.ground_a = g.ground_a;
    o.ground_b = g.ground_b;
    o.ground_k = g.ground_k;
    o.near = g.cam_right.w;
    return o;
}

struct FragOut {
    @location(0) lum: f32,
    @builtin(frag_depth) depth: f32,
};

// Ground plane z = 0 (ray cast, exact to the horizon) and sky.
@fragment
fn fs_background(in: BgOut) -> FragOut {
    let dir = in.dir;
    let cam_z = in.camera.z;
    let hits = dir.z < -1e-7 && cam_z > 0.0 && in.ground_b.z > 0.5;
    // distance along the optical axis to the ground (dir has unit forward component)
    let t = select(1e7, min(cam_z / max(-dir.z, 1e-12), 1e7), hits);
    let uv = dir.xy * t + in.camera.xy;
    // analytic screen derivatives of uv (exact, and free of the quad artefacts that hardware-style
    // derivatives show along the edges of the clipped full-screen triangle)
    let q = max(-dir.z, 1e-12);
    let duv_dx = in.dir_dx.xy * t + dir.xy * (t / q * in.dir_dx.z);
    let duv_dy = in.dir_dy.xy * t + dir.xy * (t / q * in.dir_dy.z);
    // the texture only where the ground is hit: a CPU rasteriser skips the branch for blocks of
    // pixels that are all sky (the same arithmetic for ground pixels as without the branch)
    var ground = 0.0;
    if (hits) {
        ground = texture_value(in.ground_k.y, in.ground_a, in.ground_b, uv, duv_dx, duv_dy);
    }
    var o: FragOut;
    // reversed-Z infinite projection: depth = near / view distance
    o.lum = select(in.camera.w, clamp(ground, 0.0, 1.0), hits);
    o.depth = select(0.0, min(in.near / t, 1.0), hits);
    return o;
}

// ---------------------------------------------------------------- objects

struct Inst {
    @location(2) m0: vec4<f32>,
    @location(3) m1: vec4<f32>,
    @location(4) m2: vec4<f32>,
    @location(5) m3: vec4<f32>,
    @location(6) size: vec4<f32>,
    @location(7) tex_a: vec4<f32>,
    @location(8) tex_b: vec4<f32>,
    @location(9) kinds: vec4<u32>,
};

struct ObjOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) local: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) world: vec3<f32>,
    @location(3) @interpolate(flat) tex_a: vec4<f32>,
    @location(4) @interpolate(flat) tex_b: vec4<f32>,
    @location(5) @interpolate(flat) kinds: vec4<u32>,
    @location(6) @interpolate(flat) size: vec4<f32>,
    @location(7) @interpolate(flat) center: vec3<f32>,
    @location(8) @interpolate(flat) r0: vec3<f32>,
    @location(9) @interpolate(flat) r1: vec3<f32>,
    @location(10) @interpolate(flat) r2: vec3<f32>,
    // rows z and w of the view-projection (columns' z, w), for the sphere's depth (a flat input
    // rather than a per-pixel storage-buffer load, see BgOut)
    @location(11) @interpolate(flat) clip_z: vec4<f32>,
    @location(12) @interpolate(flat) clip_w: vec4<f32>,
};

@vertex
fn vs_object(@location(0) pos: vec3<f32>, @location(1) normal: vec3<f32>, inst: Inst) -> ObjOut {
    let local = pos * inst.size.xyz;
    let model = mat4x4<f32>(inst.m0, inst.m1, inst.m2, inst.m3);
    let world = (model * vec4<f32>(local, 1.0)).xyz;
    var o: ObjOut;
    o.pos = g.view_proj * vec4<f32>(world, 1.0);
    o.local = local;
    o.normal = normal;
    o.world = world;
    o.tex_a = inst.tex_a;
    o.tex_b = inst.tex_b;
    o.kinds = inst.kinds;
    o.size = inst.size;
    o.center = inst.m3.xyz;
    o.r0 = inst.m0.xyz;
    o.r1 = inst.m1.xyz;
    o.r2 = inst.m2.xyz;
    let vp = g.view_proj;
    o.clip_z = vec4<f32>(vp[0].z, vp[1].z, vp[2].z, vp[3].z);
    o.clip_w = vec4<f32>(vp[0].w, vp[1].w, vp[2].w, vp[3].w);
    return o;
}

// Boxes: the face's in-plane coordinates.
@fragment
fn fs_box(in: ObjOut) -> @location(0) f32 {
    let n = abs(in.normal);
    let uv = select(select(in.local.xz, in.local.yz, n.x > 0.5), in.local.xy, n.z > 0.5);
    let v = texture_value(in.kinds.z, in.tex_a, in.tex_b, uv, dpdx(uv), dpdy(uv));
    return clamp(v, 0.0, 1.0);
}

// Cylinders: side u = r * azimuth, v = z; caps (x, y).
@fragment
fn fs_cylinder(in: ObjOut) -> @location(0) f32 {
    let side = abs(in.normal.z) < 0.5;
    let r = 0.5 * in.size.x;
    // a second azimuth with its seam on the opposite side gives seam-free derivatives
    let az = atan2(in.local.y, in.local.x);
    let az2 = atan2(-in.local.y, -in.local.x);
    let uv = select(in.local.xy, vec2<f32>(r * az, in.local.z), side);
    var duv_dx = dpdx(uv);
    var duv_dy = dpdy(uv);
    let du2_dx = r * dpdx(az2);
    let du2_dy = r * dpdy(az2);
    if (side) {
        if (abs(du2_dx) < abs(duv_dx.x)) { duv_dx.x = du2_dx; }
        if (abs(du2_dy) < abs(duv_dy.x)) { duv_dy.x = du2_dy; }
    }
    let v = texture_value(in.kinds.z, in.tex_a, in.tex_b, uv, duv_dx, duv_dy);
    return clamp(v, 0.0, 1.0);
}

// Spheres: ray-cast impostor inside the (back faces of the) bounding cube: exact silhouette and depth.
@fragment
fn fs_sphere(in: ObjOut) -> FragOut {
    let dir = normalize(in.world);
    let c = in.center;
    let r = 0.5 * in.size.x;
    let b = dot(dir, c);
    let perp = c - b * dir;
    let disc = r * r - dot(perp, perp);
    let s = sqrt(max(disc, 0.0));
    var t = b - s;
    if (t < 0.0) {
        t = b + s; // camera inside the sphere: see its inside
    }
    let hit = dir * t;
    let rel = hit - c;
    let local = vec3<f32>(dot(rel, in.r0), dot(rel, in.r1), dot(rel, in.r2));
    let uv = local.yz;
    let duv_dx = dpdx(uv);
    let duv_dy = dpdy(uv);
    let v = texture_value(in.kinds.z, in.tex_a, in.tex_b, uv, duv_dx, duv_dy);
    if (disc < 0.0 || t <= 0.0) {
        discard;
    }
    let h = vec4<f32>(hit, 1.0);
    var o: FragOut;
    o.lum = clamp(v, 0.0, 1.0);
    o.depth = clamp(dot(in.clip_z, h) / dot(in.clip_w, h), 0.0, 1.0);
    return o;
}
