// render.js: draws one head with plain WebGL2: smooth vertex normals recomputed from the
// deformed positions every frame, placed by the head's own rigid motion, its parts (teeth,
// gums, tongue) each in its own material and placed by the head's or the jaw's motion (the
// tongue shaped by the frame's tongue deltas first), its eyeballs (white, iris and pupil
// about the eye's axis) each turned by the frame's gaze and then placed by the head's
// motion, a key, fill and rim light that move with the camera (the face is always lit),
// and an optional roughness heat-map in place of the skin colour. A view looks at the
// front, at the side, at a cut-away (a plane through the mouth, midsagittal or at any
// angle about the vertical, removes the half nearest the camera, and what it cuts shows
// in section: flat colours where the inside of a mesh is seen), or through a see-through
// skin at the teeth, gums and tongue. The lips are drawn in their own colour (the server's
// `lips.bin` says how much each vertex is lip): a tint, a high-contrast look for
// lip-reading (darker lips, lighter skin, a rim light on the lips), the lip region alone
// in flat white on black (what the fit takes for the lips), or off. A head with a texture
// (the server's `uv.bin` and image) is drawn with it: each vertex of the rest mesh is
// drawn once per texture coordinate it has (a seam splits it), the per-vertex values
// gathered to those.

import { applyDeltas, motionMatrix } from "./decode.js";

const VERTEX_SHADER = `#version 300 es
uniform mat4 u_model; // the head's own motion (rigid)
uniform mat4 u_view;
uniform mat4 u_projection;
in vec3 a_position;
in vec3 a_normal;
in float a_heat;
in float a_lip; // how much the vertex is lip (tongue, in a tongue part), 0 to 1; 0 elsewhere
in vec2 a_uv; // where the vertex sits on the head's texture (v up), when it has one
out vec3 v_position;
out vec3 v_rest; // the vertex before any motion, head units: where an eye's iris is
out vec3 v_normal;
out float v_heat;
out float v_lip;
out vec2 v_uv;

void main() {
  mat4 model_view = u_view * u_model;
  vec4 p = model_view * vec4(a_position, 1.0);
  v_position = p.xyz;
  v_rest = a_position;
  v_normal = mat3(model_view) * a_normal;
  v_heat = a_heat;
  v_lip = a_lip;
  v_uv = a_uv;
  gl_Position = u_projection * p;
}`;

// Lighting in linear RGB, output in sRGB. The heat-map ramp is viridis (readable with
// colour-blindness, dark to light), the same stops as the legend in style.css.
const FRAGMENT_SHADER = `#version 300 es
precision highp float;
uniform float u_heat_scale; // roughness at the top of the ramp; 0 shows the albedo
uniform vec3 u_albedo; // sRGB
// The head's texture (sRGB) in place of u_albedo when u_textured is 1.
uniform sampler2D u_texture;
uniform float u_textured;
// An eyeball's centre and rest axis (head units) and its iris and pupil radii about the
// axis; iris radius 0 for anything but an eye.
uniform vec3 u_eye_centre;
uniform vec3 u_eye_forward;
uniform vec2 u_eye_radii;
// The cut: a plane in view space (normal, offset); fragments on its positive side are
// not drawn, and the inside of a mesh seen through the cut is flat u_section. All zero:
// no cut.
uniform vec4 u_clip;
uniform vec3 u_section; // sRGB
uniform vec3 u_lip_section; // sRGB, where v_lip x u_lip_strength is over 1/2
uniform float u_alpha; // 1 but for a see-through skin
// The lips: their albedo (sRGB) mixed into u_albedo by v_lip x strength, and a rim light
// of this strength on them (a tongue part's tongue is its "lip", rim 0). u_flat >= 0
// draws flat grey u_flat, white where lip, unlit.
uniform vec3 u_lip_albedo;
uniform float u_lip_strength;
uniform float u_lip_rim;
uniform float u_flat;
in vec3 v_position;
in vec3 v_rest;
in vec3 v_normal;
in float v_heat;
in float v_lip;
in vec2 v_uv;
out vec4 out_colour;

vec3 viridis(float t) {
  const vec3 c0 = vec3(0.267, 0.005, 0.329);
  const vec3 c1 = vec3(0.229, 0.322, 0.546);
  const vec3 c2 = vec3(0.128, 0.567, 0.551);
  const vec3 c3 = vec3(0.369, 0.789, 0.383);
  const vec3 c4 = vec3(0.993, 0.906, 0.144);
  t = clamp(t, 0.0, 1.0) * 4.0;
  if (t < 1.0) return mix(c0, c1, t);
  if (t < 2.0) return mix(c1, c2, t - 1.0);
  if (t < 3.0) return mix(c2, c3, t - 2.0);
  return mix(c3, c4, t - 3.0);
}

vec3 light(vec3 n, vec3 to_eye, vec3 direction, vec3 colour, float shininess) {
  vec3 l = normalize(direction);
  float diffuse = max(dot(n, l), 0.0);
  float specular = diffuse > 0.0 ? pow(max(dot(n, normalize(l + to_eye)), 0.0), shininess) : 0.0;
  return colour * diffuse + colour * specular * 0.12;
}

void main() {
  bool cut = dot(u_clip.xyz, u_clip.xyz) > 0.0;
  if (cut && dot(u_clip.xyz, v_position) + u_clip.w > 0.0) discard;
  if (cut && !gl_FrontFacing) {
    out_colour = vec4(v_lip * u_lip_strength > 0.5 ? u_lip_section : u_section, 1.0);
    return;
  }
  if (u_flat >= 0.0) {
    out_colour = vec4(mix(vec3(u_flat), vec3(1.0), v_lip * u_lip_strength), u_alpha);
    return;
  }
  float length_n = length(v_normal);
  vec3 n = length_n > 0.0 ? v_normal / length_n : vec3(0.0, 0.0, 1.0);
  if (!gl_FrontFacing) n = -n;
  vec3 to_eye = normalize(-v_position);
  float lip = v_lip * u_lip_strength;
  vec3 surface = u_textured > 0.5 ? texture(u_texture, vec2(v_uv.x, 1.0 - v_uv.y)).rgb : u_albedo;
  vec3 base = u_heat_scale > 0.0 ? viridis(v_heat / u_heat_scale) : mix(surface, u_lip_albedo, lip);
  if (u_eye_radii.x > 0.0) {
    vec3 d = v_rest - u_eye_centre;
    float along = dot(d, u_eye_forward);
    float across = length(d - along * u_eye_forward);
    if (along > 0.0) {
      float ring = across / u_eye_radii.x; // 0 at the axis, 1 at the iris's edge
      vec3 iris = mix(vec3(0.20, 0.33, 0.40), vec3(0.36, 0.46, 0.42), ring);
      base = across < u_eye_radii.y ? vec3(0.03) : across < u_eye_radii.x ? iris : base;
    }
  }
  vec3 albedo = pow(base, vec3(2.2));
  vec3 ambient = mix(vec3(0.10, 0.09, 0.08), vec3(0.22, 0.24, 0.28), n.y * 0.5 + 0.5);
  vec3 lit = albedo * ambient
    + albedo * light(n, to_eye, vec3(-0.5, 0.6, 0.8), vec3(1.0, 0.96, 0.9) * 0.95, 40.0)
    + albedo * light(n, to_eye, vec3(0.7, 0.1, 0.5), vec3(0.75, 0.85, 1.0) * 0.35, 20.0)
    + light(n, to_eye, vec3(0.2, 0.5, -1.0), vec3(1.0) * 0.25, 8.0);
  if (u_heat_scale <= 0.0) {
    lit += vec3(1.0, 0.92, 0.9) * u_lip_rim * lip * pow(1.0 - max(dot(n, to_eye), 0.0), 2.0);
  }
  out_colour = vec4(pow(lit, vec3(1.0 / 2.2)), u_alpha);
}`;

const IDENTITY = new Float32Array([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);

// Albedos, sRGB: skin, then the parts' materials.
const SKIN = [0.86, 0.71, 0.62];
const TEETH = [0.93, 0.9, 0.82];
const GUMS = [0.78, 0.4, 0.42];
const TONGUE = [0.74, 0.33, 0.36];
const SCLERA = [0.93, 0.92, 0.9];
const NOT_AN_EYE = new Float32Array([0, 0]);
const NO_CUT = new Float32Array([0, 0, 0, 0]);
/** What a cut shows where it goes through a mesh, sRGB: the albedo, darker and redder for skin. */
const SKIN_SECTION = [0.72, 0.36, 0.34];
const sectionOf = (albedo) => albedo.map((c) => c * 0.8);
/**
 * How the lips are drawn (`lips=` in the page's URL): `tint`, their own colour over the
 * skin's; `contrast`, for lip-reading: darker lips on a lighter skin with a rim light on
 * them; `region`, the lip region alone, flat white on black, the parts grey; `off`.
 * Each with its skin and lip albedos (sRGB) and rim light.
 */
const LIP_LOOKS = {
  tint: { skin: SKIN, lip: [0.62, 0.28, 0.31], rim: 0 },
  contrast: { skin: [0.95, 0.86, 0.8], lip: [0.46, 0.12, 0.16], rim: 0.6 },
  region: { skin: SKIN, lip: SKIN, rim: 0 },
  off: { skin: SKIN, lip: SKIN, rim: 0 },
};
export const LIP_MODES = Object.keys(LIP_LOOKS);
/** The flat grey the parts and eyes are drawn in when the lip region is shown. */
const REGION_PART_GREY = 0.5;
/** A see-through skin's opacity. */
const SEE_THROUGH_ALPHA = 0.3;

/** The looks a view can have (`view=` in the page's URL). */
export const LOOKS = ["front", "side", "cutaway", "see-through"];

/**
 * A part's material: a tongue by its role (gums where the server says a vertex is not the
 * tongue itself), teeth and gums by their names, else teeth.
 */
function partAlbedo(name, role) {
  if (role === "tongue") {
    return TONGUE;
  }
  return /gum/i.test(name) ? GUMS : TEETH;
}

/** Column-major 4x4 product a b (b applied first). */
function multiply(a, b) {
  const out = new Float32Array(16);
  for (let column = 0; column < 4; column++) {
    for (let row = 0; row < 4; row++) {
      let sum = 0;
      for (let k = 0; k < 4; k++) {
        sum += a[k * 4 + row] * b[column * 4 + k];
      }
      out[column * 4 + row] = sum;
    }
  }
  return out;
}

/** Area-weighted vertex normals of a triangle mesh (not normalized: the shader does it). */
export function vertexNormals(positions, indices, out) {
  out.fill(0);
  for (let t = 0; t < indices.length; t += 3) {
    const a = indices[t] * 3;
    const b = indices[t + 1] * 3;
    const c = indices[t + 2] * 3;
    const ux = positions[b] - positions[a];
    const uy = positions[b + 1] - positions[a + 1];
    const uz = positions[b + 2] - positions[a + 2];
    const vx = positions[c] - positions[a];
    const vy = positions[c + 1] - positions[a + 1];
    const vz = positions[c + 2] - positions[a + 2];
    const nx = uy * vz - uz * vy;
    const ny = uz * vx - ux * vz;
    const nz = ux * vy - uy * vx;
    out[a] += nx;
    out[a + 1] += ny;
    out[a + 2] += nz;
    out[b] += nx;
    out[b + 1] += ny;
    out[b + 2] += nz;
    out[c] += nx;
    out[c + 1] += ny;
    out[c + 2] += nz;
  }
  return out;
}

function compile(gl, type, source) {
  const shader = gl.createShader(type);
  gl.shaderSource(shader, source);
  gl.compileShader(shader);
  if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) {
    throw new Error(`shader: ${gl.getShaderInfoLog(shader)}`);
  }
  return shader;
}

export class HeadRenderer {
  constructor(canvas) {
    this.canvas = canvas;
    const gl = canvas.getContext("webgl2", { antialias: true });
    if (!gl) {
      throw new Error("this browser has no WebGL2, which the 3D view needs");
    }
    this.gl = gl;
    const program = gl.createProgram();
    gl.attachShader(program, compile(gl, gl.VERTEX_SHADER, VERTEX_SHADER));
    gl.attachShader(program, compile(gl, gl.FRAGMENT_SHADER, FRAGMENT_SHADER));
    gl.linkProgram(program);
    if (!gl.getProgramParameter(program, gl.LINK_STATUS)) {
      throw new Error(`shader program: ${gl.getProgramInfoLog(program)}`);
    }
    this.program = program;
    this.uniforms = {
      model: gl.getUniformLocation(program, "u_model"),
      view: gl.getUniformLocation(program, "u_view"),
      projection: gl.getUniformLocation(program, "u_projection"),
      heatScale: gl.getUniformLocation(program, "u_heat_scale"),
      albedo: gl.getUniformLocation(program, "u_albedo"),
      eyeCentre: gl.getUniformLocation(program, "u_eye_centre"),
      eyeForward: gl.getUniformLocation(program, "u_eye_forward"),
      eyeRadii: gl.getUniformLocation(program, "u_eye_radii"),
      clip: gl.getUniformLocation(program, "u_clip"),
      section: gl.getUniformLocation(program, "u_section"),
      lipSection: gl.getUniformLocation(program, "u_lip_section"),
      alpha: gl.getUniformLocation(program, "u_alpha"),
      lipAlbedo: gl.getUniformLocation(program, "u_lip_albedo"),
      lipStrength: gl.getUniformLocation(program, "u_lip_strength"),
      lipRim: gl.getUniformLocation(program, "u_lip_rim"),
      flat: gl.getUniformLocation(program, "u_flat"),
      texture: gl.getUniformLocation(program, "u_texture"),
      textured: gl.getUniformLocation(program, "u_textured"),
    };
    this.vao = gl.createVertexArray();
    this.buffers = {
      position: this.attribute("a_position", 3),
      normal: this.attribute("a_normal", 3),
      heat: this.attribute("a_heat", 1),
      lip: this.attribute("a_lip", 1),
      uv: this.attribute("a_uv", 2),
      index: gl.createBuffer(),
    };
    /** The head's texture on the GPU, or null. */
    this.texture = null;
    /**
     * With a texture, the rest-mesh vertex each drawn vertex is (a vertex on a seam is
     * drawn once per side); null without one: drawn vertices are the mesh's.
     */
    this.gather = null;
    /** Gathered copies of per-vertex values, by what they hold. */
    this.scratch = {};
    /** The last positions and lip weights given, the mesh's (laid out again with a texture). */
    this.positions = null;
    this.lipWeights = null;
    this.indexCount = 0;
    this.heatScale = 0;
    this.model = IDENTITY;
    this.jawModel = IDENTITY;
    this.parts = [];
    /** The eyeballs (setEyes), each with its model matrix (the head's after its turn). */
    this.eyes = [];
    /** The part the last frame's tongue deltas shaped, or null (every part at rest). */
    this.shapedPart = null;
    /** How the head is looked at (setLook) and the point the cut goes through (setCutCentre). */
    this.look = { mode: "front", cutDeg: 0 };
    /** The fraction of the device's pixels a side drawn (draw-scale.js). */
    this.drawScale = 1;
    /** How the lips are drawn (setLips): one of LIP_MODES and the tint's strength, 0 to 1. */
    this.lips = { mode: "tint", strength: 1 };
    this.cutCentre = [0, 0, 0];
    /** Millimetres per head unit of the rest mesh (setMesh). */
    this.mmPerUnit = 1;
    /**
     * In the side and cut-away looks, how many CSS pixels one millimetre spans where the
     * cut plane is, as last drawn (the scale bar's length); null in the other looks.
     */
    this.cssPixelsPerMm = null;
    gl.enable(gl.DEPTH_TEST);
    gl.blendFunc(gl.SRC_ALPHA, gl.ONE_MINUS_SRC_ALPHA);
  }

  /**
   * `mode`: one of LOOKS; `cutDeg`: the cut plane's turn about the vertical axis from the
   * midsagittal plane (0; 90 is the coronal plane, cutting the face away), degrees. The
   * side and cut-away views look along the cut's normal, at the cut.
   */
  setLook({ mode, cutDeg }) {
    this.look = { mode: LOOKS.includes(mode) ? mode : "front", cutDeg: Number.isFinite(cutDeg) ? cutDeg : 0 };
  }

  /** How the lips are drawn: `mode` one of LIP_MODES, `strength` 0 to 1. */
  setLips({ mode, strength }) {
    this.lips = {
      mode: LIP_MODES.includes(mode) ? mode : "tint",
      strength: Number.isFinite(strength) ? Math.max(0, Math.min(1, strength)) : 1,
    };
  }

  /**
   * How much each rest-mesh vertex is lip (decode.js parseVertexWeights), or null when the
   * server says nothing (every vertex skin).
   */
  setLipTint(weights) {
    const gl = this.gl;
    this.lipWeights = weights;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffers.lip);
    const mesh = weights ?? new Float32Array(this.normals.length / 3);
    gl.bufferSubData(gl.ARRAY_BUFFER, 0, this.gathered(mesh, 1, "lip"));
  }

  /**
   * `values` (`width` per rest-mesh vertex) as the drawn vertices hold them: the same
   * array without a texture, else gathered into a scratch array kept under `name`.
   */
  gathered(values, width, name) {
    if (!this.gather) {
      return values;
    }
    const count = this.gather.length * width;
    if (this.scratch[name]?.length !== count) {
      this.scratch[name] = new Float32Array(count);
    }
    const out = this.scratch[name];
    for (let i = 0; i < this.gather.length; i++) {
      const from = this.gather[i] * width;
      for (let k = 0; k < width; k++) {
        out[i * width + k] = values[from + k];
      }
    }
    return out;
  }

  /**
   * The buffers the skin is drawn from, for `drawn` vertices and the triangles `indices`
   * (into them), with their texture coordinates `uvs` (2 per drawn vertex) or none.
   */
  layOutSkin(indices, drawn, uvs) {
    const gl = this.gl;
    gl.bindVertexArray(this.vao);
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, this.buffers.index);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, indices, gl.STATIC_DRAW);
    gl.bindVertexArray(null);
    for (const [buffer, width, usage] of [
      [this.buffers.position, 3, gl.DYNAMIC_DRAW],
      [this.buffers.normal, 3, gl.DYNAMIC_DRAW],
      [this.buffers.heat, 1, gl.DYNAMIC_DRAW],
      [this.buffers.lip, 1, gl.STATIC_DRAW],
    ]) {
      gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
      gl.bufferData(gl.ARRAY_BUFFER, drawn * width * 4, usage);
    }
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffers.uv);
    gl.bufferData(gl.ARRAY_BUFFER, uvs ?? new Float32Array(drawn * 2), gl.STATIC_DRAW);
    this.indexCount = indices.length;
  }

  /**
   * The head's texture: `coords` from decode.js parseTextureCoords (for the rest mesh's
   * triangles) and the image (an ImageBitmap). Each rest-mesh vertex is drawn once per
   * texture coordinate its triangles give it.
   */
  setTexture({ coords, corners }, image) {
    const gl = this.gl;
    const coordCount = coords.length / 2;
    const drawnOf = new Map();
    const gather = [];
    const uvs = [];
    const indices = new Uint32Array(this.indices.length);
    for (let i = 0; i < this.indices.length; i++) {
      const vertex = this.indices[i];
      const uv = corners[i];
      const key = vertex * coordCount + uv;
      let drawn = drawnOf.get(key);
      if (drawn === undefined) {
        drawn = gather.length;
        drawnOf.set(key, drawn);
        gather.push(vertex);
        uvs.push(coords[2 * uv], coords[2 * uv + 1]);
      }
      indices[i] = drawn;
    }
    this.gather = Uint32Array.from(gather);
    this.layOutSkin(indices, gather.length, new Float32Array(uvs));
    if (!this.texture) {
      this.texture = gl.createTexture();
    }
    gl.bindTexture(gl.TEXTURE_2D, this.texture);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA, gl.RGBA, gl.UNSIGNED_BYTE, image);
    gl.generateMipmap(gl.TEXTURE_2D);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR_MIPMAP_LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
    gl.bindTexture(gl.TEXTURE_2D, null);
    this.setLipTint(this.lipWeights);
    if (this.positions) {
      this.setPositions(this.positions);
    }
  }

  /** Back to the skin's own colour, one drawn vertex per rest-mesh vertex. */
  dropTexture() {
    if (this.texture) {
      this.gl.deleteTexture(this.texture);
    }
    this.texture = null;
    this.gather = null;
    this.scratch = {};
  }

  /** The point the cut plane goes through (head units, before the head's motion). */
  setCutCentre(point) {
    this.cutCentre = [...point];
  }

  /** The cut plane's normal in head coordinates: +x turned by cutDeg about +y towards +z. */
  cutNormal() {
    const a = (this.look.cutDeg * Math.PI) / 180;
    return [Math.cos(a), 0, Math.sin(a)];
  }

  /** The camera's turn from the front for this look, radians (0 from the front). */
  cameraTurn() {
    if (this.look.mode !== "side" && this.look.mode !== "cutaway") {
      return 0;
    }
    const [x, , z] = this.look.mode === "side" ? [1, 0, 0] : this.cutNormal();
    return Math.atan2(x, z);
  }

  /** The cut plane in view space for u_clip (none unless the look is the cut-away). */
  clipPlane(view) {
    if (this.look.mode !== "cutaway") {
      return NO_CUT;
    }
    const modelView = multiply(view, this.model);
    const n = this.cutNormal();
    const c = this.cutCentre;
    const normal = [0, 1, 2].map((row) => modelView[row] * n[0] + modelView[4 + row] * n[1] + modelView[8 + row] * n[2]);
    const point = [0, 1, 2].map(
      (row) => modelView[row] * c[0] + modelView[4 + row] * c[1] + modelView[8 + row] * c[2] + modelView[12 + row],
    );
    return new Float32Array([...normal, -(normal[0] * point[0] + normal[1] * point[1] + normal[2] * point[2])]);
  }

  /**
   * CSS pixels per millimetre at the cut centre for `view` and `projection`: the side and
   * cut-away cameras look along the cut's normal, so the whole cut plane is at about this
   * scale.
   */
  pixelsPerMmAtCut(view, projection) {
    const modelView = multiply(view, this.model);
    const c = this.cutCentre;
    const depth = -(modelView[2] * c[0] + modelView[6] * c[1] + modelView[10] * c[2] + modelView[14]);
    const pixelsPerUnit = (projection[5] * this.canvas.clientHeight) / 2 / depth;
    return pixelsPerUnit / this.mmPerUnit;
  }

  attribute(name, size, vao = this.vao) {
    const gl = this.gl;
    const buffer = gl.createBuffer();
    const location = gl.getAttribLocation(this.program, name);
    gl.bindVertexArray(vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
    gl.enableVertexAttribArray(location);
    gl.vertexAttribPointer(location, size, gl.FLOAT, false, 0, 0);
    gl.bindVertexArray(null);
    return buffer;
  }

  /** A new rest mesh (from decode.js parseMesh): buffers sized for it, shown at rest. */
  setMesh(mesh) {
    this.mmPerUnit = mesh.mmPerUnit;
    this.indices = mesh.indices;
    this.normals = new Float32Array(mesh.positions.length);
    this.dropTexture();
    this.lipWeights = null;
    this.layOutSkin(mesh.indices, mesh.vertexCount, null); // zero lip weights until setLipTint
    this.model = IDENTITY;
    this.jawModel = IDENTITY;
    this.setParts([]);
    this.setEyes([]);
    this.setPositions(mesh.positions);
  }

  /**
   * The head's parts: `[{ name, role, mesh, tongue }]`, meshes from parseMesh (shared,
   * never written); `tongue`, for a tongue part whose server says which of its vertices
   * are the tongue itself (decode.js parseVertexWeights), else absent: those are drawn as
   * tongue and the rest (gums, the floor of the mouth) as gums. They are rigid: positions
   * and normals go to the GPU once, and each frame only moves them, except the tongue,
   * which a frame may also shape (setTongue).
   */
  setParts(parts) {
    this.parts.forEach((part) => this.release(part));
    this.shapedPart = null;
    this.parts = parts.map(({ name, role, mesh, tongue }) => {
      const uploaded = this.upload(mesh, role === "tongue");
      if (tongue) {
        uploaded.buffers.push(this.vertexWeights(uploaded.vao, tongue));
      }
      const albedo = partAlbedo(name, role);
      return {
        ...uploaded,
        role,
        albedo: tongue ? GUMS : albedo,
        tongueAlbedo: tongue ? albedo : null,
        mesh,
        // A shaped part's positions (made on its first shaping), rewritten whenever the
        // part is shaped or put back at rest.
        positions: null,
      };
    });
  }

  /** A per-vertex weight (a_lip) for a part's vertex array: its buffer. */
  vertexWeights(vao, weights) {
    const gl = this.gl;
    const buffer = this.attribute("a_lip", 1, vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
    gl.bufferData(gl.ARRAY_BUFFER, weights, gl.STATIC_DRAW);
    return buffer;
  }

  /**
   * The head's eyeballs: `[{ eye, mesh }]`, `eye` the snapshot's entry (centre, forward,
   * iris and pupil radii, head units), meshes from parseMesh. Rigid: each frame only turns
   * them (setEyeMotions).
   */
  setEyes(eyes) {
    this.eyes.forEach((eye) => this.release(eye));
    this.eyes = eyes.map(({ eye, mesh }) => ({
      ...this.upload(mesh, false),
      centre: new Float32Array(eye.centre),
      forward: new Float32Array(eye.forward),
      radii: new Float32Array([eye.iris_radius, eye.pupil_radius]),
      turn: IDENTITY,
      modelMatrix: this.model,
    }));
  }

  /** A rigid mesh's buffers on the GPU (`dynamic` when it will be reshaped). */
  upload(mesh, dynamic) {
    const gl = this.gl;
    const vao = gl.createVertexArray();
    const position = this.attribute("a_position", 3, vao);
    const normal = this.attribute("a_normal", 3, vao);
    const index = gl.createBuffer();
    gl.bindVertexArray(vao); // no heat: parts are drawn with the ramp off
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, index);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, mesh.indices, gl.STATIC_DRAW);
    gl.bindVertexArray(null);
    const usage = dynamic ? gl.DYNAMIC_DRAW : gl.STATIC_DRAW;
    const normals = vertexNormals(mesh.positions, mesh.indices, new Float32Array(mesh.positions.length));
    gl.bindBuffer(gl.ARRAY_BUFFER, position);
    gl.bufferData(gl.ARRAY_BUFFER, mesh.positions, usage);
    gl.bindBuffer(gl.ARRAY_BUFFER, normal);
    gl.bufferData(gl.ARRAY_BUFFER, normals, usage);
    return { vao, buffers: [position, normal, index], count: mesh.indices.length, normals };
  }

  /** Gives an uploaded mesh's buffers back. */
  release({ vao, buffers }) {
    this.gl.deleteVertexArray(vao);
    buffers.forEach((b) => this.gl.deleteBuffer(b));
  }

  /**
   * A frame's eye turns (decode.js `frame.eyes`, each `{eye, motion}`); eyes not listed
   * look ahead. An index past the
   * head's eyes is a problem for people (none while the eyes are still loading).
   */
  setEyeMotions(turns) {
    for (const eye of this.eyes) {
      eye.turn = IDENTITY;
    }
    for (const { eye, motion } of turns) {
      if (this.eyes.length === 0) {
        return null;
      }
      if (!this.eyes[eye]) {
        return `A frame turns eye ${eye}; the head has ${this.eyes.length}.`;
      }
      this.eyes[eye].turn = motionMatrix(motion);
    }
    this.placeEyes();
    return null;
  }

  /** Each eye's model matrix: the head's motion after the eye's turn. */
  placeEyes() {
    for (const eye of this.eyes) {
      eye.modelMatrix = eye.turn === IDENTITY ? this.model : multiply(this.model, eye.turn);
    }
  }

  /**
   * A frame's tongue deltas (decode.js `frame.tongue`, with its `step`): the part
   * they name is drawn at rest + counts x step (then moved by the jaw's and the head's
   * motion as before); null puts the shaped part back at rest. Returns a problem for
   * people when the deltas do not fit the parts (none while the parts are still loading).
   * Allocates nothing but the part's scratch arrays, once.
   */
  setTongue(tongue, step) {
    if (tongue === null) {
      if (this.shapedPart !== null) {
        this.uploadPart(this.shapedPart, this.shapedPart.mesh.positions);
        this.shapedPart = null;
      }
      return null;
    }
    if (this.parts.length === 0) {
      return null; // the parts' meshes have not arrived yet
    }
    const part = this.parts[tongue.part];
    if (!part || part.mesh.vertexCount !== tongue.vertexCount) {
      const found = part ? `it has ${part.mesh.vertexCount}` : `the head has ${this.parts.length} parts`;
      return `A frame shapes part ${tongue.part} as ${tongue.vertexCount} vertices; ${found}.`;
    }
    if (this.shapedPart !== null && this.shapedPart !== part) {
      this.uploadPart(this.shapedPart, this.shapedPart.mesh.positions);
    }
    part.positions ??= new Float32Array(part.mesh.positions.length);
    applyDeltas(part.mesh.positions, tongue, step, part.positions);
    this.uploadPart(part, part.positions);
    this.shapedPart = part;
    return null;
  }

  /** A part's positions and their normals to the GPU. */
  uploadPart(part, positions) {
    const gl = this.gl;
    vertexNormals(positions, part.mesh.indices, part.normals);
    gl.bindBuffer(gl.ARRAY_BUFFER, part.buffers[0]);
    gl.bufferSubData(gl.ARRAY_BUFFER, 0, positions);
    gl.bindBuffer(gl.ARRAY_BUFFER, part.buffers[1]);
    gl.bufferSubData(gl.ARRAY_BUFFER, 0, part.normals);
  }

  /** Deformed positions (flat xyz, same vertex count as the mesh). */
  setPositions(positions) {
    const gl = this.gl;
    this.positions = positions;
    vertexNormals(positions, this.indices, this.normals);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffers.position);
    gl.bufferSubData(gl.ARRAY_BUFFER, 0, this.gathered(positions, 3, "position"));
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffers.normal);
    gl.bufferSubData(gl.ARRAY_BUFFER, 0, this.gathered(this.normals, 3, "normal"));
  }

  /**
   * The head's motion and the jaw's (column-major 4x4, from decode.js motionMatrix): skin
   * and skull parts are placed by the head's, jaw and tongue parts by the head's after
   * the jaw's.
   */
  setMotion(head, jaw) {
    this.model = head;
    this.jawModel = multiply(head, jaw);
    this.placeEyes();
  }

  /** Per-vertex roughness coloured on a ramp from 0 to `scale`; null shows skin. */
  setHeat(values, scale) {
    this.heatScale = values ? scale : 0;
    if (values) {
      const gl = this.gl;
      gl.bindBuffer(gl.ARRAY_BUFFER, this.buffers.heat);
      gl.bufferSubData(gl.ARRAY_BUFFER, 0, this.gathered(values, 1, "heat"));
    }
  }

  /** Changes the top of the ramp while a heat-map is shown. */
  setHeatScale(scale) {
    if (this.heatScale > 0) {
      this.heatScale = scale;
    }
  }

  /** Draws with `scale` (0..1) of the device's pixels a side (draw-scale.js), from the next draw. */
  setDrawScale(scale) {
    this.drawScale = scale;
  }

  /** Matches the drawing buffer to the canvas's CSS size at the draw scale; true when it changed. */
  fitCanvas() {
    const ratio = (window.devicePixelRatio || 1) * this.drawScale;
    const width = Math.max(1, Math.round(this.canvas.clientWidth * ratio));
    const height = Math.max(1, Math.round(this.canvas.clientHeight * ratio));
    if (this.canvas.width === width && this.canvas.height === height) {
      return false;
    }
    this.canvas.width = width;
    this.canvas.height = height;
    return true;
  }

  /** Gives the GPU context back now rather than at garbage collection. */
  dispose() {
    this.gl.getExtension("WEBGL_lose_context")?.loseContext();
  }

  draw(camera) {
    const gl = this.gl;
    this.fitCanvas();
    gl.viewport(0, 0, this.canvas.width, this.canvas.height);
    gl.clearColor(0.125, 0.14, 0.165, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    if (this.indexCount === 0) {
      return;
    }
    const { view, projection } = camera.matrices(this.canvas.width / this.canvas.height, this.cameraTurn());
    const fromTheSide = this.look.mode === "side" || this.look.mode === "cutaway";
    this.cssPixelsPerMm = fromTheSide ? this.pixelsPerMmAtCut(view, projection) : null;
    const seeThrough = this.look.mode === "see-through";
    gl.useProgram(this.program);
    gl.uniformMatrix4fv(this.uniforms.view, false, view);
    gl.uniformMatrix4fv(this.uniforms.projection, false, projection);
    gl.uniform4fv(this.uniforms.clip, this.clipPlane(view));
    gl.uniform1f(this.uniforms.alpha, 1);
    const region = this.lips.mode === "region";
    if (!seeThrough) {
      this.drawSkin();
    }
    gl.uniform1f(this.uniforms.heatScale, 0);
    gl.uniform1f(this.uniforms.flat, region ? REGION_PART_GREY : -1);
    // A tongue part's tongue is its "lip": its own albedo and section, no rim; none in the
    // lip region's look, where every part is one flat grey. Parts have no texture.
    gl.uniform1f(this.uniforms.textured, 0);
    gl.uniform1f(this.uniforms.lipStrength, region ? 0 : 1);
    gl.uniform1f(this.uniforms.lipRim, 0);
    for (const part of this.parts) {
      gl.uniformMatrix4fv(this.uniforms.model, false, part.role === "skull" ? this.model : this.jawModel);
      gl.uniform3fv(this.uniforms.albedo, part.albedo);
      gl.uniform3fv(this.uniforms.section, sectionOf(part.albedo));
      const tongue = part.tongueAlbedo ?? part.albedo;
      gl.uniform3fv(this.uniforms.lipAlbedo, tongue);
      gl.uniform3fv(this.uniforms.lipSection, sectionOf(tongue));
      gl.bindVertexArray(part.vao);
      gl.drawElements(gl.TRIANGLES, part.count, gl.UNSIGNED_INT, 0);
    }
    gl.uniform3fv(this.uniforms.albedo, SCLERA);
    gl.uniform3fv(this.uniforms.section, sectionOf(SCLERA));
    for (const eye of this.eyes) {
      gl.uniformMatrix4fv(this.uniforms.model, false, eye.modelMatrix);
      gl.uniform3fv(this.uniforms.eyeCentre, eye.centre);
      gl.uniform3fv(this.uniforms.eyeForward, eye.forward);
      gl.uniform2fv(this.uniforms.eyeRadii, eye.radii);
      gl.bindVertexArray(eye.vao);
      gl.drawElements(gl.TRIANGLES, eye.count, gl.UNSIGNED_INT, 0);
    }
    gl.uniform2fv(this.uniforms.eyeRadii, NOT_AN_EYE);
    if (seeThrough) {
      // Last, blended over what is inside it, and hiding none of it from the depth test.
      gl.enable(gl.BLEND);
      gl.depthMask(false);
      gl.uniform1f(this.uniforms.alpha, SEE_THROUGH_ALPHA);
      this.drawSkin();
      gl.uniform1f(this.uniforms.alpha, 1);
      gl.depthMask(true);
      gl.disable(gl.BLEND);
    }
    gl.bindVertexArray(null);
  }

  /** The deformed skin, with the heat-map when one is on, and the lips in their look. */
  drawSkin() {
    const gl = this.gl;
    const lipLook = LIP_LOOKS[this.lips.mode];
    gl.uniform3fv(this.uniforms.lipAlbedo, lipLook.lip);
    gl.uniform3fv(this.uniforms.lipSection, SKIN_SECTION);
    // A texture has the lips' own colour: the tint is for heads without one.
    const tinted = !(this.texture && this.lips.mode === "tint");
    const strength = this.lips.mode === "region" ? 1 : this.lips.strength;
    gl.uniform1f(this.uniforms.lipStrength, tinted ? strength : 0);
    gl.uniform1f(this.uniforms.textured, this.texture ? 1 : 0);
    if (this.texture) {
      gl.activeTexture(gl.TEXTURE0);
      gl.bindTexture(gl.TEXTURE_2D, this.texture);
      gl.uniform1i(this.uniforms.texture, 0);
    }
    gl.uniform1f(this.uniforms.lipRim, lipLook.rim);
    gl.uniformMatrix4fv(this.uniforms.model, false, this.model);
    gl.uniform1f(this.uniforms.heatScale, this.heatScale);
    gl.uniform1f(this.uniforms.flat, this.lips.mode === "region" && this.heatScale === 0 ? 0 : -1);
    gl.uniform3fv(this.uniforms.albedo, LIP_LOOKS[this.lips.mode].skin);
    gl.uniform3fv(this.uniforms.section, SKIN_SECTION);
    gl.bindVertexArray(this.vao);
    gl.drawElements(gl.TRIANGLES, this.indexCount, gl.UNSIGNED_INT, 0);
  }
}
