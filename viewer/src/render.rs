//! The wgpu renderer: draws a [`SceneMesh`] and the 2-D layer into a colour target, offscreen
//! (headless, read back as RGBA for PNG files) or into a window's surface ([`crate::window`]).
//!
//! # How it works
//! 1. [`GpuContext::headless`] picks an adapter without any window: on a machine without a GPU
//!    that is Mesa's lavapipe (Vulkan on the CPU); `WGPU_BACKEND=gl` selects EGL/llvmpipe.
//! 2. [`Renderer`] owns three pipelines sharing one uniform block: lit tissue (Blinn-Phong,
//!    two-sided, fragments beyond the cut plane discarded), lines (alpha-blended springs and
//!    outlines) and flat 2-D triangles (background and overlay); 4× multisampling by default.
//! 3. Each frame the vertex data is uploaded into buffers that only grow, one render pass
//!    draws background → tissue → lines → overlay, and [`Offscreen`] copies the resolved image
//!    into a mapped buffer.

use bytemuck::{Pod, Zeroable};

use crate::camera::Camera;
use crate::cut::CutPlane;
use crate::overlay::FlatVertex;
use crate::scene_mesh::{LineVertex, LitVertex, SceneMesh};
use crate::volume::{VolumeImage, VoxelFormat};

/// Why the GPU could not be set up.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RendererCreateError {
    /// No Vulkan, GL or Metal adapter was found (on Debian: install `mesa-vulkan-drivers`).
    #[error(
        "no GPU adapter (Vulkan or GL) found: {0}; on a machine without a GPU install a software driver \
         (Debian: apt-get install mesa-vulkan-drivers libvulkan1)"
    )]
    NoAdapter(String),
    /// The adapter refused to create a device.
    #[error("the GPU adapter refused to create a device: {0}")]
    RequestDevice(String),
}

/// Why a frame could not be read back.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameReadError {
    /// Mapping the readback buffer failed or the device was lost.
    #[error("cannot read the frame back from the GPU: {0}")]
    Map(String),
}

/// Instance, adapter, device and queue.
#[derive(Debug)]
pub struct GpuContext {
    /// The wgpu instance (needed to create window surfaces).
    pub instance: wgpu::Instance,
    /// The chosen adapter.
    pub adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
}

impl GpuContext {
    /// Opens the default adapter without a window (honours `WGPU_BACKEND`).
    pub fn headless() -> Result<Self, RendererCreateError> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        Self::with_instance(instance, None)
    }

    /// Opens an adapter on `instance`, compatible with `surface` when given.
    pub fn with_instance(
        instance: wgpu::Instance,
        surface: Option<&wgpu::Surface<'_>>,
    ) -> Result<Self, RendererCreateError> {
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: surface,
            apply_limit_buckets: false,
        }))
        .map_err(|e| RendererCreateError::NoAdapter(e.to_string()))?;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("lamina-viewer"),
            required_features: wgpu::Features::empty(),
            // Volume textures as large as the adapter allows (the downlevel default is 256³).
            required_limits: wgpu::Limits {
                max_texture_dimension_3d: adapter.limits().max_texture_dimension_3d,
                ..wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits())
            },
            ..Default::default()
        }))
        .map_err(|e| RendererCreateError::RequestDevice(e.to_string()))?;
        Ok(Self { instance, adapter, device, queue })
    }

    /// "name (backend, device type)" of the adapter, for logs.
    pub fn describe(&self) -> String {
        let info = self.adapter.get_info();
        format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type)
    }
}

/// The uniform block (layout matches `Globals` in `shader.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct Globals {
    view_proj: [[f32; 4]; 4],
    eye: [f32; 4],
    clip_plane: [f32; 4],
    key_light: [f32; 4],
    fill_light: [f32; 4],
    volume_min: [f32; 4],
    volume_scale: [f32; 4],
}

/// A vertex buffer that grows to fit and is rewritten each frame.
#[derive(Debug)]
struct GrowBuffer {
    buffer: wgpu::Buffer,
    usage: wgpu::BufferUsages,
    label: &'static str,
}

impl GrowBuffer {
    fn new(device: &wgpu::Device, label: &'static str, usage: wgpu::BufferUsages) -> Self {
        let usage = usage | wgpu::BufferUsages::COPY_DST;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: 1 << 16,
            usage,
            mapped_at_creation: false,
        });
        Self { buffer, usage, label }
    }

    fn write(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, bytes: &[u8]) {
        if bytes.len() as u64 > self.buffer.size() {
            let size = (bytes.len() as u64).next_power_of_two();
            self.buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(self.label),
                size,
                usage: self.usage,
                mapped_at_creation: false,
            });
        }
        if !bytes.is_empty() {
            queue.write_buffer(&self.buffer, 0, bytes);
        }
    }
}

/// Everything one frame draws.
#[derive(Debug, Clone, Copy)]
pub struct DrawInput<'a> {
    /// The tessellated scene.
    pub mesh: &'a SceneMesh,
    /// The camera.
    pub camera: &'a Camera,
    /// The cut plane (lit geometry marked for clipping is discarded beyond it).
    pub cut: Option<CutPlane>,
    /// 2-D triangles drawn first (the background).
    pub background: &'a [FlatVertex],
    /// 2-D triangles drawn last (text, legend).
    pub overlay: &'a [FlatVertex],
    /// The volume texture drawn on the tissue (`None`: the materials' flat colours). Uploaded
    /// when a volume is first drawn (reduced to the device's largest 3D texture if needed).
    pub volume: Option<&'a VolumeImage>,
}

/// The pipelines and buffers that draw a frame into a colour target of a fixed format and size.
#[derive(Debug)]
pub struct Renderer {
    format: wgpu::TextureFormat,
    samples: u32,
    width: u32,
    height: u32,
    lit: wgpu::RenderPipeline,
    lines: wgpu::RenderPipeline,
    flat: wgpu::RenderPipeline,
    globals: wgpu::Buffer,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    bind_group: wgpu::BindGroup,
    /// The uploaded volume: its id, box corner and 1 / box size, grey or colour.
    volume: Option<(u64, glam::Vec3, glam::Vec3, bool)>,
    vertices: GrowBuffer,
    indices: GrowBuffer,
    line_vertices: GrowBuffer,
    flat_vertices: GrowBuffer,
    msaa: Option<wgpu::TextureView>,
    depth: wgpu::TextureView,
}

const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

impl Renderer {
    /// Pipelines for targets of `format`, `width × height`, `samples` (1 or 4) per pixel.
    pub fn new(gpu: &GpuContext, format: wgpu::TextureFormat, width: u32, height: u32, samples: u32) -> Self {
        let device = &gpu.device;
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("lamina shader"),
            source: wgpu::ShaderSource::Wgsl(include_str!("shader.wgsl").into()),
        });
        let globals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("globals"),
            size: core::mem::size_of::<Globals>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("globals"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D3,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("volume"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            address_mode_w: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let placeholder =
            VolumeImage::new([1, 1, 1], VoxelFormat::Rgba, vec![255; 4], glam::Vec3::ZERO, glam::Vec3::ONE);
        let bind_group = Self::volume_bind_group(gpu, &layout, &globals, &sampler, &placeholder);
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("lamina"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let blend = Some(wgpu::BlendState::ALPHA_BLENDING);
        let make = |label: &str,
                    vs: &str,
                    fs: &str,
                    attributes: &[wgpu::VertexAttribute],
                    stride: usize,
                    topology: wgpu::PrimitiveTopology,
                    depth: (bool, wgpu::CompareFunction),
                    blend: Option<wgpu::BlendState>| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &shader,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: stride as u64,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes,
                    })],
                },
                primitive: wgpu::PrimitiveState { topology, cull_mode: None, ..Default::default() },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(depth.0),
                    depth_compare: Some(depth.1),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: wgpu::MultisampleState { count: samples, ..Default::default() },
                fragment: Some(wgpu::FragmentState {
                    module: &shader,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState { format, blend, write_mask: wgpu::ColorWrites::ALL })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let lit = make(
            "lit",
            "vs_lit",
            "fs_lit",
            &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x4, 3 => Float32x2, 4 => Float32x4],
            core::mem::size_of::<LitVertex>(),
            wgpu::PrimitiveTopology::TriangleList,
            (true, wgpu::CompareFunction::Less),
            None,
        );
        let lines = make(
            "lines",
            "vs_line",
            "fs_line",
            &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4],
            core::mem::size_of::<LineVertex>(),
            wgpu::PrimitiveTopology::LineList,
            (false, wgpu::CompareFunction::LessEqual),
            blend,
        );
        let flat = make(
            "flat",
            "vs_flat",
            "fs_line",
            &wgpu::vertex_attr_array![0 => Float32x2, 1 => Float32x4],
            core::mem::size_of::<FlatVertex>(),
            wgpu::PrimitiveTopology::TriangleList,
            (false, wgpu::CompareFunction::Always),
            blend,
        );
        let vertex = wgpu::BufferUsages::VERTEX;
        let (msaa, depth) = Self::targets(device, format, width, height, samples);
        Self {
            format,
            samples,
            width,
            height,
            lit,
            lines,
            flat,
            globals,
            layout,
            sampler,
            bind_group,
            volume: None,
            vertices: GrowBuffer::new(device, "lit vertices", vertex),
            indices: GrowBuffer::new(device, "lit indices", wgpu::BufferUsages::INDEX),
            line_vertices: GrowBuffer::new(device, "line vertices", vertex),
            flat_vertices: GrowBuffer::new(device, "flat vertices", vertex),
            msaa,
            depth,
        }
    }

    fn targets(
        device: &wgpu::Device,
        format: wgpu::TextureFormat,
        width: u32,
        height: u32,
        samples: u32,
    ) -> (Option<wgpu::TextureView>, wgpu::TextureView) {
        let size = wgpu::Extent3d { width: width.max(1), height: height.max(1), depth_or_array_layers: 1 };
        let texture = |label, format, samples| {
            device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size,
                    mip_level_count: 1,
                    sample_count: samples,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                    view_formats: &[],
                })
                .create_view(&Default::default())
        };
        let msaa = (samples > 1).then(|| texture("msaa colour", format, samples));
        (msaa, texture("depth", DEPTH_FORMAT, samples))
    }

    /// Uploads `volume` into a 3D texture and returns the bind group that samples it.
    fn volume_bind_group(
        gpu: &GpuContext,
        layout: &wgpu::BindGroupLayout,
        globals: &wgpu::Buffer,
        sampler: &wgpu::Sampler,
        volume: &VolumeImage,
    ) -> wgpu::BindGroup {
        let [width, height, depth] = volume.size;
        let format = match volume.format {
            VoxelFormat::Grey => wgpu::TextureFormat::R8Unorm,
            VoxelFormat::Rgba => wgpu::TextureFormat::Rgba8UnormSrgb,
        };
        let size = wgpu::Extent3d { width, height, depth_or_array_layers: depth };
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("volume"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        // One slab of z slices at a time keeps each staging copy small.
        let row = width * volume.format.bytes() as u32;
        let slice_bytes = row as usize * height as usize;
        let slab = ((64usize << 20) / slice_bytes.max(1)).max(1) as u32;
        let mut z = 0;
        while z < depth {
            let n = slab.min(depth - z);
            let start = z as usize * slice_bytes;
            gpu.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d { x: 0, y: 0, z },
                    aspect: wgpu::TextureAspect::All,
                },
                &volume.data[start..start + n as usize * slice_bytes],
                wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(row), rows_per_image: Some(height) },
                wgpu::Extent3d { width, height, depth_or_array_layers: n },
            );
            z += n;
        }
        let view = texture.create_view(&Default::default());
        gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("globals"),
            layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: globals.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&view) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(sampler) },
            ],
        })
    }

    /// Uploads `volume` unless it is the one already uploaded.
    fn use_volume(&mut self, gpu: &GpuContext, volume: &VolumeImage) {
        if self.volume.is_some_and(|v| v.0 == volume.id()) {
            return;
        }
        let max = gpu.device.limits().max_texture_dimension_3d;
        let fitted = volume.fitted(max);
        let upload = fitted.as_ref().unwrap_or(volume);
        self.bind_group = Self::volume_bind_group(gpu, &self.layout, &self.globals, &self.sampler, upload);
        let grey = volume.format == VoxelFormat::Grey;
        self.volume = Some((volume.id(), volume.box_min, volume.box_size.recip(), grey));
    }

    /// Changes the target size (a window was resized); a zero size is ignored.
    pub fn resize(&mut self, gpu: &GpuContext, width: u32, height: u32) {
        if width == 0 || height == 0 || (width, height) == (self.width, self.height) {
            return;
        }
        (self.width, self.height) = (width, height);
        (self.msaa, self.depth) = Self::targets(&gpu.device, self.format, width, height, self.samples);
    }

    /// Target width and height, pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Records and submits one frame into `target` (a view of a texture of this renderer's
    /// format and size). Returns at once; the GPU works asynchronously.
    pub fn draw(&mut self, gpu: &GpuContext, target: &wgpu::TextureView, input: &DrawInput<'_>) {
        let (device, queue) = (&gpu.device, &gpu.queue);
        let aspect = self.width as f32 / self.height.max(1) as f32;
        let cam = input.camera;
        let forward = (cam.target - cam.eye).normalize();
        let right = forward.cross(cam.up).normalize();
        let up = right.cross(forward);
        let key = (-right * 0.55 + up * 0.85 - forward * 0.45).normalize();
        let fill = (right * 0.8 + up * 0.1 - forward * 0.5).normalize();
        if let Some(volume) = input.volume {
            self.use_volume(gpu, volume);
        }
        let (volume_min, volume_scale) = match (input.volume, self.volume) {
            (Some(_), Some((_, min, scale, grey))) => (min.extend(1.0), scale.extend(if grey { 1.0 } else { 0.0 })),
            _ => (glam::Vec4::ZERO, glam::Vec4::ONE),
        };
        let globals = Globals {
            view_proj: cam.view_proj(aspect).to_cols_array_2d(),
            eye: cam.eye.extend(1.0).to_array(),
            clip_plane: input.cut.map_or([0.0, 0.0, 0.0, -1.0], |c| c.as_vec4()),
            key_light: key.extend(1.0).to_array(),
            fill_light: fill.extend(0.35).to_array(),
            volume_min: volume_min.to_array(),
            volume_scale: volume_scale.to_array(),
        };
        queue.write_buffer(&self.globals, 0, bytemuck::bytes_of(&globals));
        let mesh = input.mesh;
        self.vertices.write(device, queue, bytemuck::cast_slice(&mesh.vertices));
        self.indices.write(device, queue, bytemuck::cast_slice(&mesh.indices));
        self.line_vertices.write(device, queue, bytemuck::cast_slice(&mesh.lines));
        let mut flat = Vec::with_capacity(input.background.len() + input.overlay.len());
        flat.extend_from_slice(input.background);
        flat.extend_from_slice(input.overlay);
        self.flat_vertices.write(device, queue, bytemuck::cast_slice(&flat));

        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        {
            let (view, resolve_target) = match &self.msaa {
                Some(msaa) => (msaa, Some(target)),
                None => (target, None),
            };
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("scene"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.depth,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &self.bind_group, &[]);
            let background = input.background.len() as u32;
            if background > 0 {
                pass.set_pipeline(&self.flat);
                pass.set_vertex_buffer(0, self.flat_vertices.buffer.slice(..));
                pass.draw(0..background, 0..1);
            }
            if !mesh.indices.is_empty() {
                pass.set_pipeline(&self.lit);
                pass.set_vertex_buffer(0, self.vertices.buffer.slice(..));
                pass.set_index_buffer(self.indices.buffer.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..mesh.indices.len() as u32, 0, 0..1);
            }
            if !mesh.lines.is_empty() {
                pass.set_pipeline(&self.lines);
                pass.set_vertex_buffer(0, self.line_vertices.buffer.slice(..));
                pass.draw(0..mesh.lines.len() as u32, 0..1);
            }
            if !input.overlay.is_empty() {
                pass.set_pipeline(&self.flat);
                pass.set_vertex_buffer(0, self.flat_vertices.buffer.slice(..));
                pass.draw(background..background + input.overlay.len() as u32, 0..1);
            }
        }
        queue.submit([encoder.finish()]);
    }
}

/// Waits until the GPU has finished all submitted work.
pub fn wait_idle(gpu: &GpuContext) {
    // A lost device surfaces at the next submit or map; nothing useful to do here.
    let _ = gpu.device.poll(wgpu::PollType::wait_indefinitely());
}

/// An offscreen colour target and its readback buffer.
#[derive(Debug)]
pub struct Offscreen {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    readback: wgpu::Buffer,
    padded_row: u32,
    width: u32,
    height: u32,
}

/// The offscreen format: 8-bit sRGB, so PNG files get display-ready values.
pub const OFFSCREEN_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

impl Offscreen {
    /// A `width × height` target (both at least 1).
    pub fn new(gpu: &GpuContext, width: u32, height: u32) -> Self {
        let (width, height) = (width.max(1), height.max(1));
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("offscreen"),
            size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: OFFSCREEN_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        let padded_row = (width * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let readback = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: u64::from(padded_row) * u64::from(height),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        Self { texture, view, readback, padded_row, width, height }
    }

    /// The view to draw into.
    pub fn view(&self) -> &wgpu::TextureView {
        &self.view
    }

    /// Copies the image to the CPU: `width × height` RGBA8 (sRGB) pixels, rows top to bottom.
    pub fn read(&self, gpu: &GpuContext, out: &mut Vec<u8>) -> Result<(), FrameReadError> {
        let mut encoder =
            gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback") });
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &self.readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.padded_row),
                    rows_per_image: Some(self.height),
                },
            },
            wgpu::Extent3d { width: self.width, height: self.height, depth_or_array_layers: 1 },
        );
        gpu.queue.submit([encoder.finish()]);
        let slice = self.readback.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        gpu.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| FrameReadError::Map(e.to_string()))?;
        rx.recv().map_err(|e| FrameReadError::Map(e.to_string()))?.map_err(|e| FrameReadError::Map(e.to_string()))?;
        {
            let data = slice.get_mapped_range().map_err(|e| FrameReadError::Map(e.to_string()))?;
            out.clear();
            let row = (self.width * 4) as usize;
            for chunk in data.chunks(self.padded_row as usize).take(self.height as usize) {
                out.extend_from_slice(&chunk[..row]);
            }
        }
        self.readback.unmap();
        Ok(())
    }
}
