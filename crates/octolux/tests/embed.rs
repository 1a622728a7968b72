//! The embedding API's checks and errors: a device short of octolux's limits is refused with
//! the limits named; a caller's G-buffer of the wrong size or format, a bad camera, and edits
//! with stale ids or bad data are clear errors; the input pass converts every documented depth
//! and normal convention to the same surfaces. (The example renderer's tests compare whole
//! images against octolux's own renderer.)

use crate::common;

use glam::{Mat4, Vec3};
use octolux::embed::*;
use octolux::scene::{Light, Material, Mesh};

/// A device on the default adapter with exactly `limits`.
fn device_with(limits: wgpu::Limits) -> (wgpu::Device, wgpu::Queue) {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter =
        pollster::block_on(instance.request_adapter(&Default::default())).expect("adapter");
    pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        required_limits: limits,
        ..Default::default()
    }))
    .expect("device")
}

#[test]
fn a_device_short_of_octoluxs_limits_is_refused_naming_them() {
    let needed = required_limits();
    // WebGPU's defaults: below what octolux's passes bind.
    let mut short = wgpu::Limits::default();
    assert!(
        short.max_storage_buffers_per_shader_stage < needed.max_storage_buffers_per_shader_stage
    );
    short.max_storage_buffers_per_shader_stage = needed.max_storage_buffers_per_shader_stage - 1;
    let (device, queue) = device_with(short);
    let error = match GiEngine::new(&device, &queue, GiConfig::new(64, 64, "lpv")) {
        Ok(_) => panic!("a device below the required limits was accepted"),
        Err(e) => e.to_string(),
    };
    assert!(
        error.contains(&format!(
            "max_storage_buffers_per_shader_stage is {}, octolux needs {}",
            needed.max_storage_buffers_per_shader_stage - 1,
            needed.max_storage_buffers_per_shader_stage
        )),
        "{error}"
    );
    let (device, queue) = device_with(needed);
    GiEngine::new(&device, &queue, GiConfig::new(64, 64, "lpv"))
        .expect("the required limits suffice");
}

fn quad_mesh() -> Mesh {
    Mesh {
        name: "floor".into(),
        positions: vec![
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, -1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(-1.0, 0.0, 1.0),
        ],
        normals: Vec::new(),
        uvs: Vec::new(),
        indices: vec![0, 2, 1, 0, 3, 2],
        material: 0,
    }
}

fn target(
    device: &wgpu::Device,
    format: wgpu::TextureFormat,
    w: u32,
    h: u32,
    usage: wgpu::TextureUsages,
) -> wgpu::TextureView {
    texture(device, format, w, h, usage).create_view(&Default::default())
}

fn texture(
    device: &wgpu::Device,
    format: wgpu::TextureFormat,
    w: u32,
    h: u32,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: None,
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

#[test]
fn bad_gbuffers_cameras_and_edits_are_clear_errors() {
    let (device, queue) = device_with(required_limits());
    let mut gi = GiEngine::new(&device, &queue, GiConfig::new(32, 32, "lpv")).expect("engine");
    let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::RENDER_ATTACHMENT;
    let depth = target(&device, wgpu::TextureFormat::Depth32Float, 32, 32, usage);
    let normal = target(&device, wgpu::TextureFormat::Rgba16Float, 32, 32, usage);
    let camera = CameraInput::new(
        Mat4::look_at_rh(Vec3::new(0.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y),
        Mat4::perspective_rh(0.8, 1.0, 0.1, 20.0),
    );
    let record = |gi: &mut GiEngine, input: FrameInput| {
        let mut encoder = device.create_command_encoder(&Default::default());
        let result = gi.record(&mut encoder, &input);
        queue.submit([encoder.finish()]);
        result.err().map(|e| e.to_string())
    };
    let input = |depth, normal| FrameInput {
        camera,
        gbuffer: GBufferInput::new(
            depth,
            DepthConvention::Standard,
            normal,
            NormalEncoding::WORLD,
        ),
        time: 0.0,
    };
    // Nothing to light yet.
    let e = record(&mut gi, input(&depth, &normal)).expect("an empty scene must fail");
    assert!(e.contains("no triangles"), "{e}");

    let material = gi.add_material(Material::default());
    let mut bad = quad_mesh();
    bad.positions[1].x = f32::NAN;
    let e = gi
        .add_mesh(bad, material)
        .expect_err("NaN position")
        .to_string();
    assert!(e.contains("floor") && e.contains("non-finite"), "{e}");
    let mesh = gi.add_mesh(quad_mesh(), material).expect("mesh");
    let e = gi
        .add_instance(mesh, Mat4::ZERO, Motion::Static)
        .expect_err("singular")
        .to_string();
    assert!(e.contains("invertible"), "{e}");
    let instance = gi
        .add_instance(mesh, Mat4::IDENTITY, Motion::Movable)
        .expect("instance");
    gi.remove_instance(instance).expect("remove");
    let e = gi
        .set_transform(instance, Mat4::IDENTITY)
        .expect_err("stale id")
        .to_string();
    assert!(e.contains("removed"), "{e}");
    gi.add_instance(mesh, Mat4::IDENTITY, Motion::Static)
        .expect("instance");
    let e = gi
        .add_light(Light::point(
            Vec3::new(0.0, f32::INFINITY, 0.0),
            Vec3::ONE,
            1.0,
        ))
        .expect_err("infinite light")
        .to_string();
    assert!(e.contains("finite"), "{e}");
    gi.add_light(Light::point(Vec3::new(0.0, 1.0, 0.0), Vec3::ONE, 1.0))
        .expect("light");
    assert!(gi.set_technique("lpv-typo", &Default::default()).is_err());

    // The G-buffer: size, format, usage.
    let small = target(&device, wgpu::TextureFormat::Depth32Float, 16, 32, usage);
    let e = record(&mut gi, input(&small, &normal)).expect("wrong size");
    assert!(e.contains("16x32") && e.contains("32x32"), "{e}");
    let uint = target(&device, wgpu::TextureFormat::Rgba8Uint, 32, 32, usage);
    let e = record(&mut gi, input(&depth, &uint)).expect("integer normals");
    assert!(e.contains("Rgba8Uint"), "{e}");
    let unbound = target(
        &device,
        wgpu::TextureFormat::Rgba16Float,
        32,
        32,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    );
    let e = record(&mut gi, input(&depth, &unbound)).expect("no binding usage");
    assert!(e.contains("TEXTURE_BINDING"), "{e}");
    // The camera.
    let mut bad_camera = input(&depth, &normal);
    bad_camera.camera.proj = Mat4::ZERO;
    let e = record(&mut gi, bad_camera).expect("singular projection");
    assert!(e.contains("camera"), "{e}");
    // And a good frame after all that.
    assert_eq!(record(&mut gi, input(&depth, &normal)), None);
    assert!(gi.indirect_view().is_some());
}

/// Octolux's view of a caller's camera keeps the view and the x/y projection and maps the
/// caller's near and far planes (or near and MAX_DEPTH_RATIO x near for an infinite one) to 0
/// and 1, for standard, reversed and infinite reversed projections alike.
#[test]
fn cameras_of_every_depth_convention_map_to_octoluxs_standard_depth() {
    let view = Mat4::look_at_rh(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y);
    let (near, far) = (0.1, 40.0);
    let standard = Mat4::perspective_rh(0.9, 1.5, near, far);
    let reversed = Mat4::perspective_rh(0.9, 1.5, far, near);
    let infinite = Mat4::perspective_infinite_reverse_rh(0.9, 1.5, near);
    let reference = CameraInput::new(view, standard)
        .octolux_view(30, 20)
        .expect("standard");
    assert!((reference.proj - standard).abs_diff_eq(Mat4::ZERO, 1e-5));
    let from_reversed = CameraInput::new(view, reversed)
        .octolux_view(30, 20)
        .expect("reversed");
    assert!(
        from_reversed.proj.abs_diff_eq(standard, 1e-4),
        "{:?}",
        from_reversed.proj
    );
    let from_infinite = CameraInput::new(view, infinite)
        .octolux_view(30, 20)
        .expect("infinite");
    let p = from_infinite.proj * glam::Vec4::new(0.0, 0.0, -near, 1.0);
    assert!((p.z / p.w).abs() < 1e-6, "near maps to {}", p.z / p.w);
    let far_point = from_infinite.proj
        * glam::Vec4::new(0.0, 0.0, -near * octolux::scene::MAX_DEPTH_RATIO, 1.0);
    assert!((far_point.z / far_point.w - 1.0).abs() < 1e-4);
    assert_eq!(from_infinite.view, view);
    assert!((from_infinite.position - Vec3::new(1.0, 2.0, 3.0)).length() < 1e-5);
}

/// `bytes` (rows of texels of `format`) in a texture the input pass can read.
fn upload(
    ctx: &octolux::gpu::GpuContext,
    format: wgpu::TextureFormat,
    (w, h): (u32, u32),
    bytes: &[u8],
) -> wgpu::TextureView {
    let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
    let texture = texture(&ctx.device, format, w, h, usage);
    let texel = format.block_copy_size(None).expect("colour format");
    ctx.queue.write_texture(
        texture.as_image_copy(),
        bytes,
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(w * texel),
            rows_per_image: Some(h),
        },
        texture.size(),
    );
    texture.create_view(&Default::default())
}

fn octahedral(n: Vec3) -> [f32; 2] {
    let p = glam::Vec2::new(n.x, n.y) / (n.x.abs() + n.y.abs() + n.z.abs());
    if n.z >= 0.0 {
        return p.to_array();
    }
    let sign = |v: f32| if v >= 0.0 { 1.0 } else { -1.0 };
    [(1.0 - p.y.abs()) * sign(p.x), (1.0 - p.x.abs()) * sign(p.y)]
}

/// One way a caller may store its G-buffer, with the error bound of its encoding.
struct Case {
    what: &'static str,
    convention: DepthConvention,
    proj: Mat4,
    encoding: NormalEncoding,
    format: wgpu::TextureFormat,
    normals: Vec<u8>,
    bound: f64,
}

/// Octolux's own G-buffer of the Cornell box, re-encoded on the CPU in every depth and normal
/// convention the input pass accepts (`R32Float` depth standard and reversed, normals in world
/// and view space, plain, unorm and octahedral), gives the same indirect irradiance as
/// octolux's renderer reading its own G-buffer. `lpv` recomputes everything every frame, so the
/// images differ only by the conversion: 32-bit floats differ by rounding (relMSE < 1e-5), 8-bit
/// unorm normals by their quantisation (1/255: relMSE < 1e-3).
#[test]
fn every_depth_and_normal_convention_reads_as_octoluxs_own_gbuffer() {
    use octolux::render::{RenderSettings, Renderer};
    let ctx = common::context();
    let scene = octolux::scene::cornell::scene();
    let size = (48, 40);
    let settings = RenderSettings {
        width: size.0,
        height: size.1,
        gi: "lpv".into(),
        ..RenderSettings::default()
    };
    let mut renderer = Renderer::new(&ctx, &scene, settings).expect("renderer");
    renderer.render(&scene, 0.0).expect("frame");
    let expected = renderer.engine().read_indirect().expect("indirect");
    let gbuffer = renderer.read_gbuffer().expect("gbuffer");
    let view = *renderer.last_view().expect("view");
    // Octolux's x/y projection with depth reversed over the camera's near and far planes.
    let (near, far) = (scene.cameras[0].near, scene.cameras[0].far);
    let mut reversed_proj = view.proj;
    reversed_proj.z_axis.z = near / (far - near);
    reversed_proj.w_axis.z = near * far / (far - near);
    let inv_proj = view.proj.inverse();
    let ndc = |i: usize, d: f32| {
        let (x, y) = (
            (i as u32 % size.0) as f32 + 0.5,
            (i as u32 / size.0) as f32 + 0.5,
        );
        glam::Vec4::new(
            x / size.0 as f32 * 2.0 - 1.0,
            1.0 - y / size.1 as f32 * 2.0,
            d,
            1.0,
        )
    };
    let standard: Vec<f32> = gbuffer.depth.clone();
    let reversed: Vec<f32> = gbuffer
        .depth
        .iter()
        .enumerate()
        .map(|(i, &d)| {
            if d >= 1.0 {
                return 0.0;
            }
            let v = inv_proj * ndc(i, d);
            let c = reversed_proj * (v / v.w);
            c.z / c.w
        })
        .collect();
    let f32_bytes = |v: &[f32]| bytemuck::cast_slice::<f32, u8>(v).to_vec();
    let world = &gbuffer.normal;
    let in_view: Vec<Vec3> = world
        .iter()
        .map(|&n| view.view.transform_vector3(n))
        .collect();
    let xyz = |normals: &[Vec3]| -> Vec<u8> {
        f32_bytes(
            &normals
                .iter()
                .flat_map(|n| [n.x, n.y, n.z, 0.0])
                .collect::<Vec<_>>(),
        )
    };
    let xyz_unorm = |normals: &[Vec3]| -> Vec<u8> {
        normals
            .iter()
            .flat_map(|n| {
                let q = |c: f32| ((c * 0.5 + 0.5) * 255.0).round() as u8;
                [q(n.x), q(n.y), q(n.z), 255]
            })
            .collect()
    };
    let oct = |normals: &[Vec3]| -> Vec<u8> {
        f32_bytes(
            &normals
                .iter()
                .flat_map(|&n| {
                    let e = octahedral(n.normalize_or(Vec3::Z));
                    [e[0], e[1], 0.0, 0.0]
                })
                .collect::<Vec<_>>(),
        )
    };
    let oct_unorm = |normals: &[Vec3]| -> Vec<u8> {
        normals
            .iter()
            .flat_map(|&n| {
                let e = octahedral(n.normalize_or(Vec3::Z));
                let q = |c: f32| ((c * 0.5 + 0.5) * 255.0).round() as u8;
                [q(e[0]), q(e[1]), 0, 255]
            })
            .collect()
    };
    use wgpu::TextureFormat::{R32Float, Rgba32Float, Rgba8Unorm};
    let cases = [
        Case {
            what: "standard, world xyz",
            convention: DepthConvention::Standard,
            proj: view.proj,
            encoding: NormalEncoding {
                space: NormalSpace::World,
                packing: NormalPacking::Xyz,
            },
            format: Rgba32Float,
            normals: xyz(world),
            bound: 1e-5,
        },
        Case {
            what: "reversed, view xyz",
            convention: DepthConvention::Reversed,
            proj: reversed_proj,
            encoding: NormalEncoding {
                space: NormalSpace::View,
                packing: NormalPacking::Xyz,
            },
            format: Rgba32Float,
            normals: xyz(&in_view),
            bound: 1e-5,
        },
        Case {
            what: "reversed, world octahedral",
            convention: DepthConvention::Reversed,
            proj: reversed_proj,
            encoding: NormalEncoding {
                space: NormalSpace::World,
                packing: NormalPacking::Octahedral,
            },
            format: Rgba32Float,
            normals: oct(world),
            bound: 1e-5,
        },
        Case {
            what: "standard, view unorm",
            convention: DepthConvention::Standard,
            proj: view.proj,
            encoding: NormalEncoding {
                space: NormalSpace::View,
                packing: NormalPacking::XyzUnorm,
            },
            format: Rgba8Unorm,
            normals: xyz_unorm(&in_view),
            bound: 1e-3,
        },
        Case {
            what: "standard, world octahedral unorm",
            convention: DepthConvention::Standard,
            proj: view.proj,
            encoding: NormalEncoding {
                space: NormalSpace::World,
                packing: NormalPacking::OctahedralUnorm,
            },
            format: Rgba8Unorm,
            normals: oct_unorm(world),
            bound: 1e-3,
        },
    ];
    let config = GiConfig::new(size.0, size.1, "lpv");
    let mut gi =
        GiEngine::with_context(&ctx.with_own_ledger(), scene.clone(), config).expect("engine");
    for Case {
        what,
        convention,
        proj,
        encoding,
        format,
        normals,
        bound,
    } in cases
    {
        let depth = match convention {
            DepthConvention::Standard => f32_bytes(&standard),
            DepthConvention::Reversed => f32_bytes(&reversed),
        };
        let depth = upload(&ctx, R32Float, size, &depth);
        let normal = upload(&ctx, format, size, &normals);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        gi.record(
            &mut encoder,
            &FrameInput {
                camera: CameraInput::new(view.view, proj),
                gbuffer: GBufferInput::new(&depth, convention, &normal, encoding),
                time: 0.0,
            },
        )
        .expect(what);
        ctx.queue.submit([encoder.finish()]);
        let got = gi.read_indirect().expect("indirect");
        let error = octolux::metrics::rel_mse(&got, &expected, None).expect("sizes");
        println!("{what}: relMSE {error:.2e}");
        assert!(
            error < bound,
            "{what}: relMSE {error:.3e} against octolux's own G-buffer"
        );
    }
}

#[test]
fn vct_svo_facing_binds_exactly_the_required_storage_buffers() {
    // The radiance's facing is vct-svo's default and binds the most storage buffers of any
    // pass: the required limits are its count. One fewer is refused when the context is made
    // (naming the limit); exactly that many runs every kernel of the technique.
    use octolux::gi::vct::FACING_STORAGE_BUFFERS;
    use octolux::render::{RenderSettings, Renderer};
    let scene = octolux::scene::cornell::scene();
    assert_eq!(
        FACING_STORAGE_BUFFERS,
        required_limits().max_storage_buffers_per_shader_stage
    );
    let context = |stage_buffers: u32| {
        let (device, queue) = device_with(wgpu::Limits {
            max_storage_buffers_per_shader_stage: stage_buffers,
            ..required_limits()
        });
        octolux::gpu::GpuContext::from_device(&device, &queue)
    };
    let Err(error) = context(FACING_STORAGE_BUFFERS - 1) else {
        panic!("one storage buffer short, and the context was made");
    };
    let error = error.to_string();
    assert!(
        error.contains(&format!(
            "max_storage_buffers_per_shader_stage is {}, octolux needs {FACING_STORAGE_BUFFERS}",
            FACING_STORAGE_BUFFERS - 1
        )),
        "{error}"
    );
    // Counting work (as `bench` does) binds one buffer more in the counted passes.
    let ctx = context(FACING_STORAGE_BUFFERS).unwrap().with_work_counter();
    let settings = RenderSettings {
        width: 32,
        height: 32,
        gi: "vct-svo".into(),
        ..RenderSettings::default()
    };
    assert!(settings.gi_settings.vct.facing);
    ctx.capture_errors(|| {
        let mut r = Renderer::new(&ctx, &scene, settings)?;
        r.render(&scene, 0.0)?;
        Ok(())
    })
    .expect("the required limits suffice");
}

#[test]
fn a_scene_handed_over_whole_is_validated_not_trusted() {
    use octolux::scene::{cornell, Keyframe, Texture, Track};
    let ctx = common::context();
    let config = || GiConfig::new(32, 32, "probes-grid");
    let fails = |scene: octolux::scene::Scene, needle: &str| {
        let e = GiEngine::with_context(&ctx, scene, config())
            .err()
            .unwrap_or_else(|| panic!("accepted a scene with {needle}"))
            .to_string();
        assert!(e.contains(needle), "'{needle}' not in: {e}");
    };
    // An index past the mesh's vertices (world_triangles indexed it and panicked).
    let mut scene = cornell::scene();
    scene.meshes[0].indices[0] = 1_000_000;
    fails(scene, "index 1000000 out of range");
    // A track without keys (sampling it read keys[0] and panicked).
    let mut scene = cornell::scene();
    scene.objects[0].animation = Some(Track {
        keys: Vec::new(),
        looping: true,
    });
    fails(scene, "animation has no keys");
    // A key far beyond the coordinate limit.
    let mut scene = cornell::scene();
    scene.objects[0].animation = Track::new(
        vec![Keyframe {
            time: 0.0,
            translation: Vec3::new(3e38, 0.0, 0.0),
            rotation: glam::Quat::IDENTITY,
        }],
        false,
    );
    fails(scene, "beyond the coordinate limit");
    // A texture of zero width (sampling it divided by zero and panicked).
    let mut scene = cornell::scene();
    scene.textures.push(Texture {
        name: "empty".into(),
        width: 0,
        height: 4,
        rgba: Vec::new(),
    });
    fails(scene, "texture 'empty'");
    // The functions themselves hold: no panic on the same data.
    let empty = Track {
        keys: Vec::new(),
        looping: false,
    };
    assert_eq!(empty.transform_at(2.0), Mat4::IDENTITY);
    let texture = Texture {
        name: "empty".into(),
        width: 0,
        height: 4,
        rgba: Vec::new(),
    };
    assert!(texture.check().is_err());
    assert_eq!(texture.sample(glam::Vec2::splat(0.5)), glam::Vec4::ONE);
    let mut mesh = quad_mesh();
    mesh.indices.push(99);
    let e = mesh.compute_normals().unwrap_err().to_string();
    assert!(e.contains("not a multiple of 3"), "{e}");
    mesh.indices.extend([99, 99]);
    let e = mesh.compute_normals().unwrap_err().to_string();
    assert!(e.contains("index 99 out of range"), "{e}");
    assert_eq!(mesh.normals.len(), mesh.positions.len());
}
