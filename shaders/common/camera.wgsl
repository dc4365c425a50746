// The pinhole camera every ray-cast pass shares (`gi_scene::CameraView` with the values the
// CPU reference derives from it), and its ray through a film point. The G-buffer and the path
// tracer cast the same rays through it, bit for bit the reference's.
#define_import_path gi::camera

// Mirror of `gi_gpu::GpuCamera`, 64 bytes.
struct Camera {
    // Pinhole position, world space.
    position: vec3<f32>,
    // tan(yfov / 2), computed on the CPU as the reference does.
    tan_half_fov: f32,
    // Unit camera axes in world space.
    right: vec3<f32>,
    // Image width over height.
    aspect: f32,
    up: vec3<f32>,
    pad_a: f32,
    forward: vec3<f32>,
    pad_b: f32,
}

// `CameraView::ray_direction`: the unit direction through the film point `uv` in [0,1]^2, u to
// the right and v downwards. The operations are the reference's, so the rays agree.
fn camera_ray(camera: Camera, uv: vec2<f32>) -> vec3<f32> {
    let fx = (2.0 * uv.x - 1.0) * camera.tan_half_fov * camera.aspect;
    let fy = (1.0 - 2.0 * uv.y) * camera.tan_half_fov;
    let d = camera.forward + fx * camera.right + fy * camera.up;
    return d * (1.0 / sqrt(dot(d, d)));
}

// Pixel coordinates (x right, y down) in an image of `size` pixels of the view-space offset `d`
// (a point minus the camera position, or a direction for a point at infinity): the inverse of
// `camera_ray`. z is 1, or 0 (and x, y are 0) when `d` lies behind the camera.
fn camera_project(camera: Camera, d: vec3<f32>, size: vec2<u32>) -> vec3<f32> {
    let z = dot(d, camera.forward);
    if z <= 0.0 {
        return vec3<f32>(0.0);
    }
    let fx = dot(d, camera.right) / (z * camera.tan_half_fov * camera.aspect);
    let fy = dot(d, camera.up) / (z * camera.tan_half_fov);
    let uv = vec2<f32>(0.5 * (fx + 1.0), 0.5 * (1.0 - fy));
    return vec3<f32>(uv * vec2<f32>(size), 1.0);
}
