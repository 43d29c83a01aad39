//! Offscreen renderer: one depth-tested render pass per view into one layer of an n × n × B
//! `R32Float` array texture, one copy of all B layers into a row-padded readback buffer, one
//! submission and one map per batch ([`Renderer::render_batch`]; [`Renderer::render`] is a batch of
//! one). Every view is drawn exactly as it would be alone (its own pass, viewport, globals and
//! instances), so a view's pixels do not depend on the batch it is in. All GPU resources are
//! created once and reused; the array and the buffers grow when a batch is larger than any before
//! it (up to what the device allows: larger batches are split into several submissions).
//! [`Renderer::submit_batch`] and [`Renderer::collect_batch`] split a batch in time: the device
//! renders the submitted views while the caller goes on (one readback buffer per batch in flight).

use std::collections::HashMap;
use std::ops::Range;
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use super::gpu::GpuContext;
use super::mesh;
use crate::SimError;
use crate::glam::{DQuat, DVec3, Mat4, Quat, Vec3, Vec4};
use crate::sensor::Sensor;
use crate::shape::PrimKind;
use crate::texture::{ResolvedTexture, TextureKind};

const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// One primitive to draw, positioned relative to the camera.
#[derive(Clone, Copy, Debug)]
pub struct RenderInstance {
    /// Primitive kind.
    pub prim: PrimKind,
    /// Centre relative to the camera position, world axes (m).
    pub position: Vec3,
    /// Orientation (world).
    pub rotation: Quat,
    /// Full extents (m).
    pub size: Vec3,
    /// Texture.
    pub texture: ResolvedTexture,
}

/// Everything that changes from frame to frame.
#[derive(Clone, Copy, Debug)]
pub struct FrameDesc<'a> {
    /// Camera position (world).
    pub camera_position: DVec3,
    /// Camera orientation: x = optical axis, z = up.
    pub camera_rotation: DQuat,
    /// Full field of view (rad).
    pub fov_rad: f64,
    /// Near clipping distance (m).
    pub near_m: f32,
    /// Sky luminance.
    pub sky: f32,
    /// Ground texture, or `None` for no ground.
    pub ground: Option<&'a ResolvedTexture>,
    /// Simulation time (drifting gratings).
    pub t_s: f64,
    /// What to draw.
    pub instances: &'a [RenderInstance],
    /// The camera's sensor, when it is not the ideal camera ([`crate::sensor`]): exposure blur over
    /// sub-frames, noise, gain, gamma, quantisation. `None` renders the view as it is.
    pub sensor: Option<SensorFrame<'a>>,
}

/// What the sensor needs to make one frame ([`FrameDesc::sensor`]).
#[derive(Clone, Copy, Debug)]
pub struct SensorFrame<'a> {
    /// The validated sensor.
    pub sensor: &'a Sensor,
    /// The simulator's seed (the noise's generator).
    pub seed: u64,
    /// The frame's index in its episode (the noise's stream).
    pub frame_index: u64,
    /// The view one camera period earlier (the start of the interpolation for the exposure's
    /// sub-frames); `None` for an episode's first frame (not blurred).
    pub previous: Option<PastView<'a>>,
}

/// The view one camera period before a frame, for the sensor's exposure blur.
#[derive(Clone, Copy, Debug)]
pub struct PastView<'a> {
    /// Camera position (world).
    pub camera_position: DVec3,
    /// Camera orientation.
    pub camera_rotation: DQuat,
    /// Simulation time (s).
    pub t_s: f64,
    /// What was drawn then (relative to the camera then), in the same order as the frame's.
    pub instances: &'a [RenderInstance],
}

/// How one frame of a submission is made from its rendered layers.
#[derive(Clone, Copy, Debug)]
struct FramePlan {
    /// Layers (sub-frames) averaged into the frame.
    layers: usize,
    /// The sensor's noise, gain, gamma and quantisation, with the generator's seed and stream.
    sensor: Option<(Sensor, u64, u64)>,
}

impl FrameDesc<'_> {
    /// Layers this frame renders: the sensor's sub-frames, or 1.
    pub fn layers(&self) -> usize {
        self.sensor.map_or(1, |s| s.sensor.views_per_frame())
    }

    /// The view a fraction `lag` ∈ [0, 1] of the way back from this one to `previous` (0 = this
    /// view, 1 = the previous one): positions interpolated linearly, rotations spherically, the
    /// instances (in the same order in both views) into `out`; returns the camera's position,
    /// rotation and the time then. The exposure's sub-frames and the event camera's adaptive
    /// sub-frames ([`crate::events`]) are made with it.
    pub fn between(&self, previous: &PastView<'_>, lag: f64, out: &mut Vec<RenderInstance>) -> (DVec3, DQuat, f64) {
        let (a, af) = (lag, lag as f32);
        out.clear();
        out.extend(
            self.instances
                .iter()
                .zip(previous.instances)
                .map(|(c, o)| RenderInstance {
                    position: c.position.lerp(o.position, af),
                    rotation: c.rotation.slerp(o.rotation, af).normalize(),
                    ..*c
                }),
        );
        (
            self.camera_position.lerp(previous.camera_position, a),
            self.camera_rotation.slerp(previous.camera_rotation, a).normalize(),
            self.t_s + (previous.t_s - self.t_s) * a,
        )
    }

    /// The sub-frame views of a frame with an exposure (camera pose, time, instances), interpolated
    /// between the previous view and this one; empty when the frame renders as one view.
    fn subframes(&self) -> Vec<(DVec3, DQuat, f64, Vec<RenderInstance>)> {
        let Some(sf) = self.sensor else { return Vec::new() };
        let k = sf.sensor.views_per_frame();
        if k == 1 {
            return Vec::new();
        }
        (0..k)
            .map(|j| {
                let a = sf.sensor.subframe_lag(j);
                match sf.previous.filter(|p| p.instances.len() == self.instances.len()) {
                    Some(p) if a > 0.0 => {
                        let mut inst = Vec::with_capacity(self.instances.len());
                        let (position, rotation, t_s) = self.between(&p, a, &mut inst);
                        (position, rotation, t_s, inst)
                    }
                    _ => (
                        self.camera_position,
                        self.camera_rotation,
                        self.t_s,
                        self.instances.to_vec(),
                    ),
                }
            })
            .collect()
    }
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Globals {
    view_proj: [[f32; 4]; 4],
    cam_fwd: [f32; 4],
    cam_right: [f32; 4],
    cam_up: [f32; 4],
    dir_dx: [f32; 4],
    dir_dy: [f32; 4],
    camera: [f32; 4],
    ground_a: [f32; 4],
    ground_b: [f32; 4],
    ground_k: [u32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct InstanceRaw {
    model: [[f32; 4]; 4],
    size: [f32; 4],
    tex_a: [f32; 4],
    tex_b: [f32; 4],
    kinds: [u32; 4],
}

fn tex_params(t: &ResolvedTexture, t_s: f64) -> ([f32; 4], [f32; 4], u32, u32) {
    (
        [t.dark, t.light, t.scale_m, t.orientation_rad],
        [t.phase_at(t_s), if t.binary { 1.0 } else { 0.0 }, 0.0, 0.0],
        t.kind as u32,
        t.seed,
    )
}

/// Bytes per row of the readback buffer: `n · 4` rounded up to wgpu's 256-byte copy alignment.
pub fn padded_bytes_per_row(n: u32) -> u32 {
    let unpadded = n * 4;
    let align = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    unpadded.div_ceil(align) * align
}

/// The four kinds of draw; each gets one pipeline per texture kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
enum Stage {
    /// Ground and sky (full-screen ray cast).
    Background,
    /// Boxes.
    Box,
    /// Cylinders.
    Cylinder,
    /// Sphere impostors.
    Sphere,
}

/// Render pipelines specialised per (stage, texture kind) through the WGSL override `TEX_KIND`, created
/// on first use. Specialisation matters on CPU rasterisers: a fragment shader that switches on the
/// texture kind at run time evaluates every case (llvmpipe runs all branches under a mask).
struct Pipelines {
    shader: wgpu::ShaderModule,
    layout: wgpu::PipelineLayout,
    cache: HashMap<(Stage, u32), wgpu::RenderPipeline>,
}

impl Pipelines {
    fn get(&self, stage: Stage, kind: u32) -> &wgpu::RenderPipeline {
        &self.cache[&(stage, kind)]
    }

    fn ensure(&mut self, device: &wgpu::Device, stage: Stage, kind: u32) {
        if self.cache.contains_key(&(stage, kind)) {
            return;
        }
        let vertex_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];
        let instance_attrs = wgpu::vertex_attr_array![
            2 => Float32x4, 3 => Float32x4, 4 => Float32x4, 5 => Float32x4,
            6 => Float32x4, 7 => Float32x4, 8 => Float32x4, 9 => Uint32x4
        ];
        let mesh_layout = |attributes| wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<mesh::Vertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes,
        };
        let instance_layout = wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<InstanceRaw>() as u64,
            step_mode: wgpu::VertexStepMode::Instance,
            attributes: &instance_attrs,
        };
        let background_buffers = [Some(mesh_layout(&vertex_attrs[..1]))];
        let object_buffers = [Some(mesh_layout(&vertex_attrs)), Some(instance_layout)];
        // sphere impostors draw the back faces of their bounding cube, which cover the sphere from any
        // viewpoint (also from inside the cube); the background writes every pixel
        let (label, vs, fs, buffers, cull, compare): (_, _, _, &[Option<wgpu::VertexBufferLayout<'_>>], _, _) =
            match stage {
                Stage::Background => (
                    "background",
                    "vs_background",
                    "fs_background",
                    &background_buffers,
                    None,
                    wgpu::CompareFunction::Always,
                ),
                Stage::Box => (
                    "box",
                    "vs_object",
                    "fs_box",
                    &object_buffers,
                    Some(wgpu::Face::Back),
                    wgpu::CompareFunction::Greater,
                ),
                Stage::Cylinder => (
                    "cylinder",
                    "vs_object",
                    "fs_cylinder",
                    &object_buffers,
                    Some(wgpu::Face::Back),
                    wgpu::CompareFunction::Greater,
                ),
                Stage::Sphere => (
                    "sphere",
                    "vs_object",
                    "fs_sphere",
                    &object_buffers,
                    Some(wgpu::Face::Front),
                    wgpu::CompareFunction::Greater,
                ),
            };
        let constants = [("TEX_KIND", f64::from(kind))];
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(&self.layout),
            vertex: wgpu::VertexState {
                module: &self.shader,
                entry_point: Some(vs),
                compilation_options: Default::default(),
                buffers,
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                front_face: wgpu::FrontFace::Ccw,
                cull_mode: cull,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(compare),
                stencil: wgpu::StencilState::default(),
                bias: wgpu::DepthBiasState::default(),
            }),
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &self.shader,
                entry_point: Some(fs),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &constants,
                    ..Default::default()
                },
                targets: &[Some(wgpu::ColorTargetState {
                    format: COLOR_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        self.cache.insert((stage, kind), pipeline);
    }
}

/// The most views one submission renders (larger batches are split); the device's limits may allow
/// fewer ([`Renderer::max_batch`]).
pub const MAX_BATCH: u32 = 256;

/// An offscreen renderer for n × n single-channel frames, one view or a batch of views per
/// submission.
///
/// Reusable across worlds with the same `n` ([`crate::Sim::with_renderer`], [`crate::Sim::into_renderer`]);
/// the GPU device can be shared between renderers of different sizes ([`Renderer::with_context`]).
pub struct Renderer {
    /// Tells this renderer's [`PendingViews`] from another's.
    id: u64,
    ctx: Arc<GpuContext>,
    n: u32,
    padded_bpr: u32,
    /// Views the target, the readback buffer and the globals buffer hold now.
    layers: u32,
    /// The most views one submission may render on this device.
    max_layers: u32,
    /// Bytes between two views' globals (the device's storage-buffer offset alignment).
    globals_stride: u64,
    color: wgpu::Texture,
    layer_views: Vec<wgpu::TextureView>,
    depth_view: wgpu::TextureView,
    /// Readback buffers of `layers` views not in use by a submission in flight (one per batch
    /// in flight: a buffer being mapped cannot be the target of the next batch's copy).
    readbacks: Vec<Readback>,
    globals: wgpu::Buffer,
    bgl: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
    mesh: wgpu::Buffer,
    cube: Range<u32>,
    cylinder: Range<u32>,
    fullscreen: Range<u32>,
    instances: wgpu::Buffer,
    capacity: usize,
    pipelines: Pipelines,
    scratch: Vec<InstanceRaw>,
    globals_scratch: Vec<u8>,
    order: Vec<(Stage, u32, usize)>,
    /// Per view: its draws `(stage, texture kind, first instance, count)` are `groups[range]`.
    groups: Vec<(Stage, u32, u32, u32)>,
    view_groups: Vec<(Range<usize>, u32)>,
    timings: RenderTimings,
}

/// A readback buffer and the state of its mapping (0: pending, 1: mapped, 2: failed).
#[derive(Debug)]
struct Readback {
    buffer: wgpu::Buffer,
    state: Arc<AtomicU8>,
}

/// Calls `push(i, value)` for the n·n pixels of the layer at byte `base` of a mapped readback
/// (rows `bpr` bytes apart), row-major.
fn read_layer(view: &[u8], base: usize, bpr: usize, n: usize, mut push: impl FnMut(usize, f32)) {
    for row in 0..n {
        let bytes = &view[base + row * bpr..base + row * bpr + n * 4];
        for (c, b) in bytes.chunks_exact(4).enumerate() {
            push(row * n + c, f32::from_ne_bytes([b[0], b[1], b[2], b[3]]));
        }
    }
}

/// Makes one frame of `plan` from its layers, starting at layer `first`: the mean of its
/// sub-frames, then the sensor's noise, gain, gamma and quantisation.
fn sensor_frame(view: &[u8], first: usize, bpr: usize, n: usize, plan: &FramePlan, out: &mut Vec<f32>) {
    out.clear();
    out.resize(n * n, 0.0);
    for l in first..first + plan.layers {
        read_layer(view, l * bpr * n, bpr, n, |i, x| out[i] += x);
    }
    if plan.layers > 1 {
        let k = plan.layers as f32;
        out.iter_mut().for_each(|v| *v /= k);
    }
    if let Some((sensor, seed, frame_index)) = plan.sensor {
        sensor.apply(out, seed, frame_index);
    }
}

/// Views submitted by [`Renderer::submit_batch`] and not yet read back: the device renders them
/// while the caller goes on (steps the next simulators' physics, encodes the next batch);
/// [`Renderer::collect_batch`] waits for them and copies their pixels out. Dropping it without
/// collecting discards the views.
#[must_use = "collect the views with Renderer::collect_batch"]
#[derive(Debug)]
pub struct PendingViews {
    renderer: u64,
    readback: Readback,
    views: usize,
    /// Per frame: its layers and sensor; empty when every frame is one plain view.
    plans: Vec<FramePlan>,
    index: wgpu::SubmissionIndex,
}

/// The id of the next [`Renderer`].
static NEXT_RENDERER_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Cumulative wall-clock time spent in the phases of [`Renderer::render`] and
/// [`Renderer::render_batch`] (for profiling; a batch's times count once, its views as `frames`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderTimings {
    /// Frames (views) rendered.
    pub frames: u64,
    /// Submissions (batches, or parts of a batch larger than [`Renderer::max_batch`]).
    pub submissions: u64,
    /// Building instance data, uploading it and encoding the passes and copy (s).
    pub encode_s: f64,
    /// `queue.submit` (s).
    pub submit_s: f64,
    /// Waiting for the GPU to finish and the buffer to map (s).
    pub wait_s: f64,
    /// Copying the mapped rows out (s).
    pub readback_s: f64,
}

impl std::fmt::Debug for Renderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Renderer")
            .field("n", &self.n)
            .field("adapter", &self.ctx.adapter_info.name)
            .finish()
    }
}

/// The GPU resources whose size depends on the number of views per submission.
struct LayerResources {
    color: wgpu::Texture,
    layer_views: Vec<wgpu::TextureView>,
    globals: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
}

impl Renderer {
    /// Creates a GPU context and a renderer for n × n frames.
    pub fn new(n: u32) -> Result<Renderer, SimError> {
        Renderer::with_context(GpuContext::new()?, n)
    }

    /// Creates a renderer for n × n frames on an existing GPU context.
    pub fn with_context(ctx: Arc<GpuContext>, n: u32) -> Result<Renderer, SimError> {
        use crate::camera::{MAX_N, MIN_FRAME_SIZE};
        if !(MIN_FRAME_SIZE..=MAX_N).contains(&n) {
            return Err(SimError::invalid(
                "world.camera.n",
                n,
                format!(
                    "must be in {MIN_FRAME_SIZE}..={MAX_N} pixels (the detectors need frames of at least \
                     {MIN_FRAME_SIZE}×{MIN_FRAME_SIZE})"
                ),
            ));
        }
        let device = &ctx.device;
        let limits = device.limits();
        if n > limits.max_texture_dimension_2d {
            return Err(SimError::invalid(
                "world.camera.n",
                n,
                format!(
                    "the GPU adapter allows frames of at most {0}×{0} pixels",
                    limits.max_texture_dimension_2d
                ),
            ));
        }
        let padded_bpr = padded_bytes_per_row(n);
        let view_bytes = u64::from(padded_bpr) * u64::from(n);
        let align = u64::from(limits.min_storage_buffer_offset_alignment.max(1));
        let globals_stride = (std::mem::size_of::<Globals>() as u64).div_ceil(align) * align;
        // the views of one submission: array layers, readback bytes and globals within the limits
        let max_layers = MAX_BATCH
            .min(limits.max_texture_array_layers)
            .min(u32::try_from(limits.max_buffer_size / view_bytes).unwrap_or(u32::MAX))
            .min(u32::try_from(limits.max_buffer_size / globals_stride).unwrap_or(u32::MAX))
            .max(1);
        let depth = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("depth"),
            size: wgpu::Extent3d {
                width: n,
                height: n,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: DEPTH_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        });
        let bgl = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("globals"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: true },
                    has_dynamic_offset: true,
                    min_binding_size: wgpu::BufferSize::new(std::mem::size_of::<Globals>() as u64),
                },
                count: None,
            }],
        });
        let layers = 1;
        let res = Self::layer_resources(device, &bgl, n, globals_stride, layers);
        let mut verts = mesh::cube();
        let cube = 0..verts.len() as u32;
        verts.extend(mesh::cylinder());
        let cylinder = cube.end..verts.len() as u32;
        verts.extend(mesh::fullscreen_triangle());
        let fullscreen = cylinder.end..verts.len() as u32;
        let mesh_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("meshes"),
            contents: bytemuck::cast_slice(&verts),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let capacity = 64;
        let instances = Self::instance_buffer(device, capacity);
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("loomlab-sim shader"),
            source: wgpu::ShaderSource::Wgsl(include_str!("shader.wgsl").into()),
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("loomlab-sim"),
            bind_group_layouts: &[Some(&bgl)],
            immediate_size: 0,
        });
        let pipelines = Pipelines {
            shader,
            layout,
            cache: HashMap::new(),
        };
        Ok(Renderer {
            id: NEXT_RENDERER_ID.fetch_add(1, Ordering::Relaxed),
            n,
            padded_bpr,
            layers,
            max_layers,
            globals_stride,
            color: res.color,
            layer_views: res.layer_views,
            depth_view: depth.create_view(&wgpu::TextureViewDescriptor::default()),
            readbacks: Vec::new(),
            globals: res.globals,
            bgl,
            bind_group: res.bind_group,
            mesh: mesh_buf,
            cube,
            cylinder,
            fullscreen,
            instances,
            capacity,
            pipelines,
            scratch: Vec::with_capacity(capacity),
            globals_scratch: Vec::new(),
            order: Vec::with_capacity(capacity),
            groups: Vec::new(),
            view_groups: Vec::new(),
            timings: RenderTimings::default(),
            ctx,
        })
    }

    fn layer_resources(
        device: &wgpu::Device,
        bgl: &wgpu::BindGroupLayout,
        n: u32,
        globals_stride: u64,
        layers: u32,
    ) -> LayerResources {
        let color = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("luminance"),
            size: wgpu::Extent3d {
                width: n,
                height: n,
                depth_or_array_layers: layers,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: COLOR_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let layer_views = (0..layers)
            .map(|layer| {
                color.create_view(&wgpu::TextureViewDescriptor {
                    label: Some("luminance layer"),
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: layer,
                    array_layer_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        let globals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("globals"),
            size: globals_stride * u64::from(layers),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("globals"),
            layout: bgl,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &globals,
                    offset: 0,
                    size: wgpu::BufferSize::new(std::mem::size_of::<Globals>() as u64),
                }),
            }],
        });
        LayerResources {
            color,
            layer_views,
            globals,
            bind_group,
        }
    }

    /// Grows the array target and its buffers to hold `views` views (at most `max_layers`).
    fn ensure_layers(&mut self, views: u32) {
        if views <= self.layers {
            return;
        }
        let layers = views.next_power_of_two().min(self.max_layers).max(views);
        let res = Self::layer_resources(&self.ctx.device, &self.bgl, self.n, self.globals_stride, layers);
        self.color = res.color;
        self.layer_views = res.layer_views;
        // buffers of the old size still in flight are dropped when collected
        self.readbacks.clear();
        self.globals = res.globals;
        self.bind_group = res.bind_group;
        self.layers = layers;
    }

    /// Bytes of a readback buffer for `layers` views.
    fn readback_bytes(&self) -> u64 {
        u64::from(self.padded_bpr) * u64::from(self.n) * u64::from(self.layers)
    }

    fn instance_buffer(device: &wgpu::Device, capacity: usize) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("instances"),
            size: (capacity * std::mem::size_of::<InstanceRaw>()) as u64,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// Frame size n.
    pub fn n(&self) -> u32 {
        self.n
    }

    /// The most views one submission renders on this device ([`MAX_BATCH`], or fewer where the
    /// device's texture-array or buffer limits require); [`Renderer::render_batch`] splits larger
    /// batches.
    pub fn max_batch(&self) -> usize {
        self.max_layers as usize
    }

    /// The GPU context (to create more renderers on the same device).
    pub fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    /// Time spent so far in each phase of rendering.
    pub fn timings(&self) -> RenderTimings {
        self.timings
    }

    /// Renders one frame and writes it to `out` (resized to n·n): luminance in [0, 1], row-major, row 0
    /// at the top of the image. The same as a batch of one ([`Renderer::render_batch`]).
    pub fn render(&mut self, frame: &FrameDesc<'_>, out: &mut Vec<f32>) -> Result<(), SimError> {
        self.render_batch(std::slice::from_ref(frame), std::slice::from_mut(out))
    }

    /// Renders `frames[i]` into `outs[i]` for every i (each resized to n·n, as [`Renderer::render`]
    /// writes it), all of them in one submission and one readback (or one per [`Self::max_batch`]
    /// views). Each view's pixels are bit-identical to rendering it alone: every view has its own
    /// render pass into its own layer, with the same pipelines, viewport and draws.
    pub fn render_batch(&mut self, frames: &[FrameDesc<'_>], outs: &mut [Vec<f32>]) -> Result<(), SimError> {
        if frames.len() != outs.len() {
            return Err(SimError::invalid(
                "render_batch outputs",
                outs.len(),
                format!("must be one per frame description ({} given)", frames.len()),
            ));
        }
        // submissions of at most max_layers layers (a frame with sub-frames takes several)
        let max = self.max_layers as usize;
        let mut ranges = Vec::new();
        let (mut start, mut layers) = (0, 0);
        for (i, f) in frames.iter().enumerate() {
            if layers + f.layers() > max && i > start {
                ranges.push(start..i);
                (start, layers) = (i, 0);
            }
            layers += f.layers();
        }
        if start < frames.len() {
            ranges.push(start..frames.len());
        }
        let mut pending = Vec::with_capacity(ranges.len());
        for r in &ranges {
            pending.push(self.submit_batch(&frames[r.clone()])?);
        }
        for (views, r) in pending.into_iter().zip(ranges) {
            self.collect_batch(views, &mut outs[r])?;
        }
        Ok(())
    }

    /// Submits `frames` (1 to [`Self::max_batch`] views) for rendering and returns at once; the
    /// device renders them while the caller goes on, and [`Renderer::collect_batch`] reads them
    /// back. Several batches may be in flight (they are rendered in submission order); each view's
    /// pixels are those [`Renderer::render`] gives. This is how [`crate::Sim::step_batch`]
    /// overlaps one group's physics with the previous group's rendering.
    pub fn submit_batch(&mut self, frames: &[FrameDesc<'_>]) -> Result<PendingViews, SimError> {
        let layers: usize = frames.iter().map(FrameDesc::layers).sum();
        if frames.is_empty() || layers > self.max_layers as usize {
            return Err(SimError::invalid(
                "submit_batch frames",
                format!("{} views ({layers} layers with the sensor's sub-frames)", frames.len()),
                format!(
                    "must be 1..={} layers (Renderer::max_batch; each frame takes \
                     world.camera.sensor.subframes layers when it has an exposure)",
                    self.max_layers
                ),
            ));
        }
        let plans: Vec<FramePlan> = if frames.iter().any(|f| f.sensor.is_some()) {
            frames
                .iter()
                .map(|f| FramePlan {
                    layers: f.layers(),
                    sensor: f.sensor.map(|s| (*s.sensor, s.seed, s.frame_index)),
                })
                .collect()
        } else {
            Vec::new()
        };
        let t_start = std::time::Instant::now();
        self.ensure_layers(layers as u32);
        let readback = self.readbacks.pop().unwrap_or_else(|| Readback {
            buffer: self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("readback"),
                size: self.readback_bytes(),
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            }),
            state: Arc::new(AtomicU8::new(0)),
        });
        let cmd = if layers == frames.len() {
            self.encode(frames, &readback.buffer)
        } else {
            // the exposure's sub-frames, each one a view of its own
            let subs: Vec<_> = frames.iter().map(FrameDesc::subframes).collect();
            let mut descs = Vec::with_capacity(layers);
            for (f, sub) in frames.iter().zip(&subs) {
                if sub.is_empty() {
                    descs.push(*f);
                }
                for (position, rotation, t_s, instances) in sub {
                    descs.push(FrameDesc {
                        camera_position: *position,
                        camera_rotation: *rotation,
                        t_s: *t_s,
                        instances,
                        sensor: None,
                        ..*f
                    });
                }
            }
            self.encode(&descs, &readback.buffer)
        };
        let t_encoded = std::time::Instant::now();
        let index = self.ctx.queue.submit(Some(cmd));
        let t_submitted = std::time::Instant::now();
        let bytes = u64::from(self.padded_bpr) * u64::from(self.n) * layers as u64;
        readback.state.store(0, Ordering::Release);
        let state = Arc::clone(&readback.state);
        readback.buffer.slice(..bytes).map_async(wgpu::MapMode::Read, move |r| {
            state.store(if r.is_ok() { 1 } else { 2 }, Ordering::Release);
        });
        let tm = &mut self.timings;
        tm.submissions += 1;
        tm.encode_s += (t_encoded - t_start).as_secs_f64();
        tm.submit_s += (t_submitted - t_encoded).as_secs_f64();
        Ok(PendingViews {
            renderer: self.id,
            readback,
            views: frames.len(),
            plans,
            index,
        })
    }

    /// Waits for the views of this renderer's [`Renderer::submit_batch`] and writes them to `outs`
    /// (one per view, each resized to n·n, as [`Renderer::render`] writes it).
    pub fn collect_batch(&mut self, pending: PendingViews, outs: &mut [Vec<f32>]) -> Result<(), SimError> {
        if pending.renderer != self.id {
            return Err(SimError::invalid(
                "collect_batch views",
                "submitted by another renderer",
                "collect views with the renderer that submitted them",
            ));
        }
        if outs.len() != pending.views {
            return Err(SimError::invalid(
                "collect_batch outputs",
                outs.len(),
                format!("must be one per submitted view ({} submitted)", pending.views),
            ));
        }
        let t_start = std::time::Instant::now();
        let device = &self.ctx.device;
        let PendingViews {
            readback,
            views,
            plans,
            index,
            ..
        } = pending;
        device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(index),
                timeout: None,
            })
            .map_err(|e| SimError::Gpu {
                during: "waiting for the frame",
                reason: e.to_string(),
            })?;
        // The callback runs during some poll; if the submission finished before the map was queued, poll
        // again. With several renderers on one device (parallel episodes), another thread's poll may be
        // the one that runs our callback, a moment after our own poll returned: wait for it (bounded).
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
        while readback.state.load(Ordering::Acquire) == 0 && std::time::Instant::now() < deadline {
            device
                .poll(wgpu::PollType::wait_indefinitely())
                .map_err(|e| SimError::Gpu {
                    during: "mapping the readback buffer",
                    reason: e.to_string(),
                })?;
            if readback.state.load(Ordering::Acquire) == 0 {
                std::thread::yield_now();
            }
        }
        if readback.state.load(Ordering::Acquire) != 1 {
            return Err(SimError::Gpu {
                during: "mapping the readback buffer",
                reason: "map_async failed".into(),
            });
        }
        let t_waited = std::time::Instant::now();
        let n = self.n as usize;
        let bpr = self.padded_bpr as usize;
        let layers = if plans.is_empty() {
            views
        } else {
            plans.iter().map(|p| p.layers).sum()
        };
        {
            let view = readback
                .buffer
                .get_mapped_range(..(bpr * n * layers) as u64)
                .map_err(|e| SimError::Gpu {
                    during: "reading back the frame",
                    reason: e.to_string(),
                })?;
            if plans.is_empty() {
                for (v, out) in outs.iter_mut().enumerate() {
                    out.clear();
                    out.reserve(n * n);
                    read_layer(&view, v * bpr * n, bpr, n, |_, x| out.push(x));
                }
            } else {
                let mut layer = 0;
                for (plan, out) in plans.iter().zip(outs.iter_mut()) {
                    sensor_frame(&view, layer, bpr, n, plan, out);
                    layer += plan.layers;
                }
            }
        }
        readback.buffer.unmap();
        if readback.buffer.size() == self.readback_bytes() {
            self.readbacks.push(readback);
        }
        let t_end = std::time::Instant::now();
        let tm = &mut self.timings;
        tm.frames += layers as u64;
        tm.wait_s += (t_waited - t_start).as_secs_f64();
        tm.readback_s += (t_end - t_waited).as_secs_f64();
        Ok(())
    }

    /// The globals of one view.
    fn globals_for(&self, frame: &FrameDesc<'_>) -> Globals {
        // camera matrices (camera at the origin of the render frame)
        let fwd = (frame.camera_rotation * DVec3::X).as_vec3();
        let up = (frame.camera_rotation * DVec3::Z).as_vec3();
        let right = (frame.camera_rotation * DVec3::NEG_Y).as_vec3();
        // viewing-ray change per pixel: the image spans 2·tan(fov/2) at unit distance
        let step = (2.0 * (frame.fov_rad / 2.0).tan() / f64::from(self.n)) as f32;
        let view = crate::glam::camera::rh::view::look_to_mat4(Vec3::ZERO, fwd, up);
        let proj = crate::glam::camera::rh::proj::directx::perspective_infinite_reverse(
            frame.fov_rad as f32,
            1.0,
            frame.near_m,
        );
        let view_proj = proj * view;
        let cam = frame.camera_position;
        let (ground_a, ground_b, gk, gs, enabled) = match frame.ground {
            Some(t) => {
                let (a, b, k, s) = tex_params(t, frame.t_s);
                (a, b, k, s, 1.0)
            }
            None => ([0.0; 4], [0.0; 4], 0, 0, 0.0),
        };
        Globals {
            view_proj: view_proj.to_cols_array_2d(),
            cam_fwd: [fwd.x, fwd.y, fwd.z, (frame.fov_rad / 2.0).tan() as f32],
            cam_right: [right.x, right.y, right.z, frame.near_m],
            cam_up: [up.x, up.y, up.z, 0.0],
            dir_dx: (right * step).extend(0.0).to_array(),
            dir_dy: (-up * step).extend(0.0).to_array(),
            camera: [cam.x as f32, cam.y as f32, cam.z as f32, frame.sky],
            ground_a,
            ground_b: [ground_b[0], ground_b[1], enabled, self.n as f32],
            ground_k: [gk, gs, 0, 0],
        }
    }

    /// Appends one view's instances to `scratch`, grouped by (stage, texture kind): one specialised
    /// pipeline and one draw per group; records its groups in `view_groups` with its ground kind.
    fn push_view(&mut self, frame: &FrameDesc<'_>) {
        self.order.clear();
        for (i, inst) in frame.instances.iter().enumerate() {
            let stage = match inst.prim {
                PrimKind::Box => Stage::Box,
                PrimKind::Cylinder => Stage::Cylinder,
                PrimKind::Sphere => Stage::Sphere,
            };
            self.order.push((stage, inst.texture.kind as u32, i));
        }
        self.order.sort_unstable();
        let first_group = self.groups.len();
        for &(stage, kind, i) in &self.order {
            let inst = &frame.instances[i];
            let model = Mat4::from_rotation_translation(inst.rotation, inst.position);
            let (tex_a, tex_b, tk, seed) = tex_params(&inst.texture, frame.t_s);
            let index = self.scratch.len() as u32;
            self.scratch.push(InstanceRaw {
                model: model.to_cols_array_2d(),
                size: Vec4::from((inst.size, 0.0)).to_array(),
                tex_a,
                tex_b,
                kinds: [inst.prim as u32, tk, seed, 0],
            });
            match self.groups[first_group..].last_mut() {
                Some(g) if g.0 == stage && g.1 == kind => g.3 += 1,
                _ => self.groups.push((stage, kind, index, 1)),
            }
        }
        let ground_kind = frame.ground.map_or(TextureKind::Uniform as u32, |t| t.kind as u32);
        self.view_groups.push((first_group..self.groups.len(), ground_kind));
    }

    /// Uploads the views' globals and instances and encodes their passes and the copy of their
    /// layers into `readback` (at most `layers` views).
    fn encode(&mut self, frames: &[FrameDesc<'_>], readback: &wgpu::Buffer) -> wgpu::CommandBuffer {
        let views = frames.len();
        self.scratch.clear();
        self.groups.clear();
        self.view_groups.clear();
        self.globals_scratch.clear();
        let stride = self.globals_stride as usize;
        for frame in frames {
            let globals = self.globals_for(frame);
            let at = self.globals_scratch.len();
            self.globals_scratch.resize(at + stride, 0);
            self.globals_scratch[at..at + std::mem::size_of::<Globals>()].copy_from_slice(bytemuck::bytes_of(&globals));
            self.push_view(frame);
        }
        for &(_, ground_kind) in &self.view_groups {
            self.pipelines.ensure(&self.ctx.device, Stage::Background, ground_kind);
        }
        for &(stage, kind, _, _) in &self.groups {
            self.pipelines.ensure(&self.ctx.device, stage, kind);
        }
        let device = &self.ctx.device;
        let queue = &self.ctx.queue;
        if self.scratch.len() > self.capacity {
            self.capacity = self.scratch.len().next_power_of_two();
            self.instances = Self::instance_buffer(device, self.capacity);
        }
        queue.write_buffer(&self.globals, 0, &self.globals_scratch);
        if !self.scratch.is_empty() {
            queue.write_buffer(&self.instances, 0, bytemuck::cast_slice(&self.scratch));
        }
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frames") });
        for (v, frame) in frames.iter().enumerate() {
            let (groups, ground_kind) = self.view_groups[v].clone();
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("frame"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &self.layer_views[v],
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: f64::from(frame.sky),
                            g: 0.0,
                            b: 0.0,
                            a: 1.0,
                        }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(0.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            // at most MAX_BATCH views of one stride (256 bytes on most devices): far below u32::MAX
            let offset = (v as u64 * self.globals_stride) as u32;
            pass.set_bind_group(0, &self.bind_group, &[offset]);
            pass.set_vertex_buffer(0, self.mesh.slice(..));
            pass.set_pipeline(self.pipelines.get(Stage::Background, ground_kind));
            pass.draw(self.fullscreen.clone(), 0..1);
            if !groups.is_empty() {
                pass.set_vertex_buffer(1, self.instances.slice(..));
                for &(stage, kind, first, count) in &self.groups[groups] {
                    pass.set_pipeline(self.pipelines.get(stage, kind));
                    let vertices = if stage == Stage::Cylinder {
                        self.cylinder.clone()
                    } else {
                        self.cube.clone()
                    };
                    pass.draw(vertices, first..first + count);
                }
            }
        }
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.color,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.padded_bpr),
                    rows_per_image: Some(self.n),
                },
            },
            wgpu::Extent3d {
                width: self.n,
                height: self.n,
                depth_or_array_layers: views as u32,
            },
        );
        encoder.finish()
    }
}

/// Converts a frame in [0, 1] to 8-bit grey levels (round to nearest, clamped).
pub fn frame_to_u8(frame: &[f32]) -> Vec<u8> {
    frame
        .iter()
        .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
        .collect()
}

#[cfg(test)]
mod tests {
    #[test]
    fn rows_are_padded_to_256_bytes() {
        for n in [1u32, 63, 64, 65, 100, 128, 256, 257] {
            let p = super::padded_bytes_per_row(n);
            assert_eq!(p % 256, 0);
            assert!(p >= n * 4 && p < n * 4 + 256);
        }
    }
}
