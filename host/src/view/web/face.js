// The face on a WebGL2 canvas for the page of `sinew view` (docs/VIEW.md): an indexed mesh lit
// and shaded from the core's per-vertex normals, or, for a mesh without faces (an S2D decoder's
// artefact stores none), its vertices as points; landmarks drawn as points over it; orbit (drag)
// and zoom (wheel) about the face's centre. Plain WebGL2 and about 50 lines of matrices.

const VERTEX_SHADER = `#version 300 es
in vec3 position;
in vec3 normal;
in vec3 tint;
uniform mat4 viewProjection;
uniform mat4 view;
out vec3 viewNormal;
out vec3 viewPosition;
out vec3 albedo;
void main() {
  albedo = tint;
  vec4 p = view * vec4(position, 1.0);
  viewPosition = p.xyz;
  viewNormal = mat3(view) * normal;
  gl_Position = viewProjection * vec4(position, 1.0);
}`;

const FRAGMENT_SHADER = `#version 300 es
precision highp float;
in vec3 viewNormal;
in vec3 viewPosition;
in vec3 albedo;
out vec4 colour;
void main() {
  vec3 n = normalize(viewNormal);
  vec3 v = normalize(-viewPosition);
  if (dot(n, v) < 0.0) n = -n;
  vec3 key = normalize(vec3(0.5, 0.6, 0.8));
  vec3 fill = normalize(vec3(-0.7, 0.1, 0.5));
  float diffuse = max(dot(n, key), 0.0) * 0.75 + max(dot(n, fill), 0.0) * 0.25;
  float sky = 0.5 + 0.5 * n.y;
  float specular = pow(max(dot(n, normalize(key + v)), 0.0), 40.0) * 0.25;
  vec3 c = albedo * (0.06 + 0.08 * sky + 0.85 * diffuse) + vec3(specular);
  colour = vec4(pow(c, vec3(1.0 / 2.2)), 1.0);
}`;

const POINT_VERTEX_SHADER = `#version 300 es
in vec3 position;
uniform mat4 viewProjection;
uniform float size;
void main() {
  gl_Position = viewProjection * vec4(position, 1.0);
  gl_PointSize = size;
}`;

const POINT_FRAGMENT_SHADER = `#version 300 es
precision highp float;
uniform vec3 tint;
out vec4 colour;
void main() {
  vec2 d = gl_PointCoord - vec2(0.5);
  if (dot(d, d) > 0.25) discard;
  colour = vec4(tint, 1.0);
}`;

/** The colour of the vertices drawn as points (sRGB). */
const CLOUD = [0.85, 0.72, 0.64];
/** The colour of the landmarks (sRGB). */
const LANDMARK = [0.2, 0.95, 0.45];

/**
 * The face on a WebGL2 canvas, with orbit (drag) and zoom (wheel) about its centre. `triangles`:
 * vertex indices, 3 per triangle (empty: the vertices are drawn as points); `neutral`: x y z per
 * vertex, which the camera frames.
 */
export class FaceView {
  constructor(canvas, triangles, neutral) {
    this.canvas = canvas;
    const gl = canvas.getContext("webgl2", { antialias: true });
    if (!gl) throw new Error("this browser has no WebGL2");
    this.gl = gl;
    this.program = program(gl, VERTEX_SHADER, FRAGMENT_SHADER);
    this.points = program(gl, POINT_VERTEX_SHADER, POINT_FRAGMENT_SHADER);
    this.indexCount = triangles.length;
    this.vao = gl.createVertexArray();
    gl.bindVertexArray(this.vao);
    this.positionBuffer = attribute(gl, this.program, "position");
    this.normalBuffer = attribute(gl, this.program, "normal");
    this.colourBuffer = attribute(gl, this.program, "tint");
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, gl.createBuffer());
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, triangles, gl.STATIC_DRAW);
    // The same positions as points, and the landmarks.
    this.cloudVao = gl.createVertexArray();
    gl.bindVertexArray(this.cloudVao);
    bindAttribute(gl, this.points, "position", this.positionBuffer);
    this.landmarkVao = gl.createVertexArray();
    gl.bindVertexArray(this.landmarkVao);
    this.landmarkBuffer = attribute(gl, this.points, "position");
    this.landmarkCount = 0;
    this.vertexCount = 0;
    gl.bindVertexArray(null);

    // Orbit about the neutral's bounding box centre, at a distance that frames it.
    const lo = [Infinity, Infinity, Infinity];
    const hi = [-Infinity, -Infinity, -Infinity];
    for (let i = 0; i < neutral.length; i += 3) {
      for (let k = 0; k < 3; k++) {
        lo[k] = Math.min(lo[k], neutral[i + k]);
        hi[k] = Math.max(hi[k], neutral[i + k]);
      }
    }
    this.centre = lo.map((l, k) => (l + hi[k]) / 2);
    this.radius = Math.hypot(...hi.map((h, k) => h - lo[k])) / 2 || 1;
    this.distance = this.radius * 2.8;
    this.yaw = 0;
    this.pitch = 0;
    this.listen();
  }

  listen() {
    const c = this.canvas;
    let last = null;
    c.addEventListener("pointerdown", (e) => {
      last = [e.clientX, e.clientY];
      c.setPointerCapture(e.pointerId);
    });
    c.addEventListener("pointerup", () => (last = null));
    c.addEventListener("pointermove", (e) => {
      if (!last) return;
      this.yaw -= (e.clientX - last[0]) * 0.01;
      this.pitch = Math.max(-1.5, Math.min(1.5, this.pitch - (e.clientY - last[1]) * 0.01));
      last = [e.clientX, e.clientY];
      this.redraw();
    });
    c.addEventListener(
      "wheel",
      (e) => {
        e.preventDefault();
        const factor = Math.exp(Math.sign(e.deltaY) * 0.1);
        this.distance = Math.max(this.radius * 0.5, Math.min(this.radius * 10, this.distance * factor));
        this.redraw();
      },
      { passive: false },
    );
    new ResizeObserver(() => this.redraw()).observe(c);
  }

  /** Sets the per-vertex colours (linear RGB, 3 per vertex) and redraws. */
  setColours(colours) {
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.colourBuffer);
    gl.bufferData(gl.ARRAY_BUFFER, colours, gl.STATIC_DRAW);
    if (this.drawn) this.redraw();
  }

  /** Draws `positions` with `normals` (x y z per vertex; normals unused without triangles). */
  draw(positions, normals) {
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.positionBuffer);
    gl.bufferData(gl.ARRAY_BUFFER, positions, gl.DYNAMIC_DRAW);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.normalBuffer);
    gl.bufferData(gl.ARRAY_BUFFER, normals, gl.DYNAMIC_DRAW);
    this.vertexCount = positions.length / 3;
    this.drawn = true;
    this.redraw();
  }

  /** Sets the landmarks drawn over the face (x y z each; empty: none), drawn at the next draw. */
  setLandmarks(landmarks) {
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.landmarkBuffer);
    gl.bufferData(gl.ARRAY_BUFFER, landmarks, gl.DYNAMIC_DRAW);
    this.landmarkCount = landmarks.length / 3;
  }

  redraw() {
    const gl = this.gl;
    const c = this.canvas;
    const scale = window.devicePixelRatio || 1;
    const [w, h] = [Math.round(c.clientWidth * scale), Math.round(c.clientHeight * scale)];
    if (w > 0 && h > 0 && (c.width !== w || c.height !== h)) [c.width, c.height] = [w, h];
    gl.viewport(0, 0, c.width, c.height);
    gl.clearColor(0x1d / 255, 0x20 / 255, 0x26 / 255, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    gl.useProgram(this.program);
    const eye = [
      this.centre[0] + this.distance * Math.cos(this.pitch) * Math.sin(this.yaw),
      this.centre[1] + this.distance * Math.sin(this.pitch),
      this.centre[2] + this.distance * Math.cos(this.pitch) * Math.cos(this.yaw),
    ];
    const view = lookAt(eye, this.centre, [0, 1, 0]);
    const near = Math.max(this.distance - this.radius * 2, this.radius * 0.01);
    const projection = perspective(Math.PI / 5, c.width / Math.max(c.height, 1), near, this.distance + this.radius * 2);
    const viewProjection = multiply(projection, view);
    if (this.indexCount > 0) {
      gl.uniformMatrix4fv(gl.getUniformLocation(this.program, "view"), false, view);
      gl.uniformMatrix4fv(gl.getUniformLocation(this.program, "viewProjection"), false, viewProjection);
      gl.bindVertexArray(this.vao);
      gl.drawElements(gl.TRIANGLES, this.indexCount, gl.UNSIGNED_INT, 0);
    } else {
      this.drawPoints(this.cloudVao, this.vertexCount, viewProjection, 3 * scale, CLOUD);
    }
    // Landmarks stay visible in front of the face.
    gl.disable(gl.DEPTH_TEST);
    this.drawPoints(this.landmarkVao, this.landmarkCount, viewProjection, 7 * scale, LANDMARK);
    gl.bindVertexArray(null);
  }

  drawPoints(vao, count, viewProjection, size, tint) {
    if (count === 0) return;
    const gl = this.gl;
    gl.useProgram(this.points);
    gl.uniformMatrix4fv(gl.getUniformLocation(this.points, "viewProjection"), false, viewProjection);
    gl.uniform1f(gl.getUniformLocation(this.points, "size"), size);
    gl.uniform3fv(gl.getUniformLocation(this.points, "tint"), tint);
    gl.bindVertexArray(vao);
    gl.drawArrays(gl.POINTS, 0, count);
  }

}

function program(gl, vertexSource, fragmentSource) {
  const p = gl.createProgram();
  for (const [type, source] of [
    [gl.VERTEX_SHADER, vertexSource],
    [gl.FRAGMENT_SHADER, fragmentSource],
  ]) {
    const s = gl.createShader(type);
    gl.shaderSource(s, source);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(`shader: ${gl.getShaderInfoLog(s)}`);
    gl.attachShader(p, s);
  }
  gl.linkProgram(p);
  if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(`shader link: ${gl.getProgramInfoLog(p)}`);
  return p;
}

/** A new buffer bound to attribute `name` of program `p` in the vertex array bound now. */
function attribute(gl, p, name) {
  return bindAttribute(gl, p, name, gl.createBuffer());
}

function bindAttribute(gl, p, name, buffer) {
  const location = gl.getAttribLocation(p, name);
  gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
  gl.enableVertexAttribArray(location);
  gl.vertexAttribPointer(location, 3, gl.FLOAT, false, 0, 0);
  return buffer;
}

/**
 * Area-weighted unit vertex normals of a triangle mesh, x y z per vertex, for drawing only (an
 * S2D decoder's faces come from `--neutral`; the core computes an AIM actor's).
 */
export function vertexNormals(positions, triangles) {
  const n = new Float32Array(positions.length);
  const p = (i, k) => positions[3 * i + k];
  for (let t = 0; t < triangles.length; t += 3) {
    const [a, b, c] = [triangles[t], triangles[t + 1], triangles[t + 2]];
    const u = [0, 1, 2].map((k) => p(b, k) - p(a, k));
    const v = [0, 1, 2].map((k) => p(c, k) - p(a, k));
    const f = cross(u, v);
    for (const i of [a, b, c]) for (let k = 0; k < 3; k++) n[3 * i + k] += f[k];
  }
  for (let i = 0; i < n.length; i += 3) {
    const len = Math.hypot(n[i], n[i + 1], n[i + 2]) || 1;
    for (let k = 0; k < 3; k++) n[i + k] /= len;
  }
  return n;
}

// Column-major 4×4 matrices, as WebGL takes them.
function lookAt(eye, target, up) {
  const z = normalise(eye.map((e, k) => e - target[k]));
  const x = normalise(cross(up, z));
  const y = cross(z, x);
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  return new Float32Array([
    x[0], y[0], z[0], 0,
    x[1], y[1], z[1], 0,
    x[2], y[2], z[2], 0,
    -dot(x, eye), -dot(y, eye), -dot(z, eye), 1,
  ]);
}

function perspective(fovY, aspect, near, far) {
  const f = 1 / Math.tan(fovY / 2);
  return new Float32Array([
    f / aspect, 0, 0, 0,
    0, f, 0, 0,
    0, 0, (far + near) / (near - far), -1,
    0, 0, (2 * far * near) / (near - far), 0,
  ]);
}

function multiply(a, b) {
  const out = new Float32Array(16);
  for (let col = 0; col < 4; col++) {
    for (let row = 0; row < 4; row++) {
      let s = 0;
      for (let k = 0; k < 4; k++) s += a[k * 4 + row] * b[col * 4 + k];
      out[col * 4 + row] = s;
    }
  }
  return out;
}

function cross(a, b) {
  return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
}

function normalise(v) {
  const n = Math.hypot(...v) || 1;
  return v.map((x) => x / n);
}

