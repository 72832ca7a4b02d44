// Lamina viewer shaders: lit tissue (Blinn-Phong, two-sided, cut-plane clipping),
// lines (springs, outlines) and the flat 2-D layer (background, overlay).

struct Globals {
    view_proj: mat4x4<f32>,
    // xyz: eye position (m).
    eye: vec4<f32>,
    // Signed distance of p to the cut plane = dot(xyz, p) + w; > 0 is removed.
    clip_plane: vec4<f32>,
    // xyz: direction toward the key light; w: intensity.
    key_light: vec4<f32>,
    // xyz: direction toward the fill light; w: intensity.
    fill_light: vec4<f32>,
    // xyz: corner of the volume texture's box, m (rest frame); w: 1 to draw the texture.
    volume_min: vec4<f32>,
    // xyz: 1 / size of that box, 1/m; w: 1 if the volume holds grey levels, 0 colours.
    volume_scale: vec4<f32>,
};

@group(0) @binding(0) var<uniform> g: Globals;
// The deformable volume texture, sampled at each point's rest position.
@group(0) @binding(1) var volume_tex: texture_3d<f32>;
@group(0) @binding(2) var volume_sampler: sampler;

struct LitIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
    @location(3) params: vec2<f32>,
    // xyz: rest position (m), the 3D texture coordinate before mapping; w: 1 if textured.
    @location(4) rest: vec4<f32>,
};

struct LitOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
    @location(3) params: vec2<f32>,
    @location(4) rest: vec4<f32>,
};

@vertex
fn vs_lit(v: LitIn) -> LitOut {
    var out: LitOut;
    out.clip = g.view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    out.color = v.color;
    out.params = v.params;
    out.rest = v.rest;
    return out;
}

fn light(n: vec3<f32>, v: vec3<f32>, dir: vec3<f32>, tint: vec3<f32>, base: vec3<f32>, spec: f32, shininess: f32) -> vec3<f32> {
    let l = normalize(dir);
    // Wrapped diffuse: soft terminator, as light scatters in tissue.
    let wrap = 0.3;
    let diffuse = max((dot(n, l) + wrap) / (1.0 + wrap), 0.0);
    let h = normalize(l + v);
    let specular = select(0.0, pow(max(dot(n, h), 0.0), shininess) * spec, dot(n, l) > 0.0);
    return tint * (base * diffuse + vec3<f32>(specular));
}

@fragment
fn fs_lit(f: LitOut) -> @location(0) vec4<f32> {
    if (f.params.y > 0.5 && dot(g.clip_plane.xyz, f.world) + g.clip_plane.w > 0.0) {
        discard;
    }
    let v = normalize(g.eye.xyz - f.world);
    var n = normalize(f.normal);
    if (dot(n, v) < 0.0) {
        n = -n;
    }
    var base = f.color.rgb;
    // The volume texture at the rest position, in place of the material's colour (trilinear;
    // outside the volume's box the material shows).
    let tc = (f.rest.xyz - g.volume_min.xyz) * g.volume_scale.xyz;
    let texel = textureSampleLevel(volume_tex, volume_sampler, tc, 0.0);
    let inside = all(tc >= vec3<f32>(0.0)) && all(tc <= vec3<f32>(1.0));
    if (g.volume_min.w > 0.5 && f.rest.w > 0.5 && inside) {
        base = select(texel.rgb, vec3<f32>(pow(texel.r, 2.2)), g.volume_scale.w > 0.5);
    }
    let sky = vec3<f32>(0.34, 0.36, 0.40);
    let ground = vec3<f32>(0.14, 0.11, 0.10);
    var c = base * mix(ground, sky, 0.5 + 0.5 * n.y);
    c += light(n, v, g.key_light.xyz, vec3<f32>(1.0, 0.96, 0.90) * g.key_light.w, base, f.color.a, f.params.x);
    c += light(n, v, g.fill_light.xyz, vec3<f32>(0.70, 0.80, 1.0) * g.fill_light.w, base, f.color.a * 0.5, f.params.x);
    // A faint rim makes silhouettes read against the dark background.
    let rim = pow(1.0 - max(dot(n, v), 0.0), 3.0) * 0.12;
    c += vec3<f32>(rim);
    return vec4<f32>(c, 1.0);
}

struct LineIn {
    @location(0) position: vec3<f32>,
    @location(1) color: vec4<f32>,
};

struct LineOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
};

@vertex
fn vs_line(v: LineIn) -> LineOut {
    var out: LineOut;
    out.clip = g.view_proj * vec4<f32>(v.position, 1.0);
    out.color = v.color;
    return out;
}

@fragment
fn fs_line(f: LineOut) -> @location(0) vec4<f32> {
    return f.color;
}

struct FlatIn {
    @location(0) position: vec2<f32>,
    @location(1) color: vec4<f32>,
};

@vertex
fn vs_flat(v: FlatIn) -> LineOut {
    var out: LineOut;
    out.clip = vec4<f32>(v.position, 0.0, 1.0);
    out.color = v.color;
    return out;
}
