//! Probe: opens the shared device, prints its limits and adapters, and checks a few float
//! rules (no FMA contraction, division, sqrt, subnormals) with one dispatch.
use shadenet_gpu::GpuContext;
use wgpu::util::DeviceExt;
fn main() {
    let ctx = GpuContext::open().unwrap();
    print!("{}", ctx.describe());
    for a in shadenet_gpu::context::adapters() {
        println!("  {:?}", a);
    }
    let src = r#"
@group(0) @binding(0) var<storage, read_write> buf: array<f32>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
  if (id.x != 0u) { return; }
  let a = buf[0]; let b = buf[1]; let c = buf[2];
  buf[3] = a * b + c;
  let p = a * b;
  buf[4] = p;
  buf[5] = buf[6] / buf[7];
  buf[8] = sqrt(buf[9]);
  buf[10] = buf[11] * 1.0; // denormal passthrough
  buf[12] = min(buf[13], 1.0);
  buf[14] = sin(buf[15]);
}"#;
    let m = ctx
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: None,
            source: wgpu::ShaderSource::Wgsl(src.into()),
        });
    let a = 1.0f32 + f32::EPSILON;
    let b = 1.0f32 - f32::EPSILON;
    let c = -1.0f32;
    let data: Vec<f32> = vec![
        a,
        b,
        c,
        0.,
        0.,
        0.,
        1.0,
        3.0,
        0.,
        2.0,
        0.,
        1e-40,
        0.,
        f32::NAN,
        0.,
        1e6,
        0.,
    ];
    let buf = ctx
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents: bytemuck::cast_slice(&data),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        });
    let rb = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: (data.len() * 4) as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let p = ctx
        .device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: None,
            layout: None,
            module: &m,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
    let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &p.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: buf.as_entire_binding(),
        }],
    });
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&p);
        pass.set_bind_group(0, &bg, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }
    enc.copy_buffer_to_buffer(&buf, 0, &rb, 0, (data.len() * 4) as u64);
    ctx.queue.submit([enc.finish()]);
    rb.slice(..).map_async(wgpu::MapMode::Read, |_| {});
    ctx.device
        .poll(wgpu::PollType::wait_indefinitely())
        .unwrap();
    let out: Vec<f32> = bytemuck::cast_slice(&rb.slice(..).get_mapped_range().unwrap()).to_vec();
    println!(
        "fused? gpu {:e} separate {:e} fma {:e}",
        out[3],
        a * b + c,
        a.mul_add(b, c)
    );
    println!(
        "div {:e} vs {:e}; sqrt {:e} vs {:e}; denorm {:e}; min(nan,1) {}; sin(1e6) {} vs {}",
        out[5],
        1.0f32 / 3.0,
        out[8],
        2f32.sqrt(),
        out[10],
        out[12],
        out[14],
        1e6f32.sin()
    );
}
