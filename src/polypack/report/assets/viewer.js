/* polypack pack viewer: a small WebGL2 renderer of ray-cast impostor spheres.
 *
 * Every sphere is one point sprite whose size bounds the sphere's exact perspective
 * silhouette; the fragment shader intersects the eye ray through the pixel with the true
 * sphere (centre, radius), writes the exact depth and shades the normal (point sprites are
 * about 20 times faster than instanced quads in software WebGL).  A clipping slab (two
 * parallel planes) is applied per fragment: where the
 * front surface is cut away the ray is continued to the slab plane and the section of the
 * sphere (a disc) is drawn, so a slice shows true cross-sections.
 *
 * Data come from a JSON block (see polypack.report.viewer): positions, radii and
 * per-particle fields as base64 little-endian typed arrays, colour maps as RGB tables.
 * Nothing is fetched: the page is self-contained.
 *
 * window.polypackViewers[i] (and window.polypackViewer, the last one) exposes
 * drawnSpheres (spheres submitted in the last frame), frames, firstFrameMs,
 * setField, setRealization, setClip, render, toPNG.
 */
(function () {
  "use strict";

  function b64(s, Type) {
    var bin = atob(s), n = bin.length, u8 = new Uint8Array(n);
    for (var i = 0; i < n; i++) u8[i] = bin.charCodeAt(i);
    return new Type(u8.buffer);
  }
  var TYPES = { f32: Float32Array, u8: Uint8Array, i32: Int32Array, u16: Uint16Array };
  function decode(arr) { return b64(arr.data, TYPES[arr.dtype]); }

  // ------------------------------------------------------------------ 4x4 matrices (column-major)
  function mat4() { var m = new Float32Array(16); m[0] = m[5] = m[10] = m[15] = 1; return m; }
  function mul(a, b) {
    var o = new Float32Array(16);
    for (var c = 0; c < 4; c++)
      for (var r = 0; r < 4; r++) {
        var s = 0;
        for (var k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k];
        o[c * 4 + r] = s;
      }
    return o;
  }
  function perspective(fovy, aspect, near, far) {
    var f = 1 / Math.tan(fovy / 2), m = new Float32Array(16);
    m[0] = f / aspect; m[5] = f; m[10] = (far + near) / (near - far); m[11] = -1;
    m[14] = 2 * far * near / (near - far);
    return m;
  }
  function translate(x, y, z) { var m = mat4(); m[12] = x; m[13] = y; m[14] = z; return m; }
  function rotX(a) { var m = mat4(), c = Math.cos(a), s = Math.sin(a); m[5] = c; m[6] = s; m[9] = -s; m[10] = c; return m; }
  function rotY(a) { var m = mat4(), c = Math.cos(a), s = Math.sin(a); m[0] = c; m[2] = -s; m[8] = s; m[10] = c; return m; }

  // ------------------------------------------------------------------ shaders
  // One point sprite per sphere: its size bounds the sphere's perspective silhouette,
  // tan(theta + alpha) - tan(theta) on either side of the projected centre (theta: angle of
  // the centre off the optical axis, alpha = asin(r / d): half-angle of the tangent cone).
  var SPHERE_VS = [
    "#version 300 es",
    "in vec3 center; in float radius; in vec4 color;",
    "uniform mat4 view; uniform mat4 proj; uniform vec2 viewport; uniform float maxPoint;",
    "flat out vec3 vCenter; flat out float vRadius; flat out vec3 vColor;",
    "void main() {",
    "  vec3 c = (view * vec4(center, 1.0)).xyz;",
    "  float d = length(c);",
    "  vColor = color.rgb; vCenter = c; vRadius = radius;",
    "  if (d <= radius * 1.0001 || -c.z <= 0.0) { gl_Position = vec4(2.0, 2.0, 2.0, 1.0); gl_PointSize = 1.0; return; }",
    "  float theta = acos(clamp(-c.z / d, -1.0, 1.0));",
    "  float alpha = asin(radius / d);",
    "  float half_ = tan(min(theta + alpha, 1.55)) - tan(theta);",
    "  gl_Position = proj * vec4(c, 1.0);",
    "  gl_PointSize = min(half_ * proj[1][1] * viewport.y + 2.0, maxPoint);",
    "}"
  ].join("\n");

  // The same spheres as instanced quads (for spheres larger on screen than the largest point
  // sprite the GPU allows): each quad lies in the plane through the centre perpendicular to
  // the line of sight, sized to the tangent cone, so it covers the exact silhouette.
  var QUAD_VS = [
    "#version 300 es",
    "in vec2 corner; in vec3 center; in float radius; in vec4 color;",
    "uniform mat4 view; uniform mat4 proj;",
    "flat out vec3 vCenter; flat out float vRadius; flat out vec3 vColor;",
    "void main() {",
    "  vec3 c = (view * vec4(center, 1.0)).xyz;",
    "  float d = length(c);",
    "  vColor = color.rgb; vCenter = c; vRadius = radius;",
    "  if (d <= radius * 1.0001) { gl_Position = vec4(2.0, 2.0, 2.0, 1.0); return; }",
    "  vec3 w = c / d;",
    "  vec3 up = abs(w.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0);",
    "  vec3 u = normalize(cross(up, w));",
    "  vec3 v = cross(w, u);",
    "  float s = radius * d / sqrt(d * d - radius * radius) * 1.02;",
    "  gl_Position = proj * vec4(c + s * (corner.x * u + corner.y * v), 1.0);",
    "}"
  ].join("\n");

  var SPHERE_FS = [
    "#version 300 es",
    "precision highp float;",
    "flat in vec3 vCenter; flat in float vRadius; flat in vec3 vColor;",
    "uniform mat4 proj; uniform vec2 viewport; uniform int clipOn; uniform vec3 clipN; uniform vec2 slab;",
    "out vec4 frag;",
    "void main() {",
    "  vec2 ndc = gl_FragCoord.xy / viewport * 2.0 - 1.0;",
    "  vec3 dir = normalize(vec3(ndc.x / proj[0][0], ndc.y / proj[1][1], -1.0));",
    "  float b = dot(dir, vCenter);",
    "  float cc = dot(vCenter, vCenter) - vRadius * vRadius;",
    "  float disc = b * b - cc;",
    "  if (disc < 0.0) discard;",
    "  float h = sqrt(disc);",
    "  float t0 = b - h, t1 = b + h, t = t0;",
    "  bool cap = false;",
    "  if (clipOn == 1) {",
    "    float dn = dot(dir, clipN);",
    "    float ta = -1e30, tb = 1e30;",
    "    if (abs(dn) > 1e-9) { ta = slab.x / dn; tb = slab.y / dn; if (ta > tb) { float q = ta; ta = tb; tb = q; } }",
    "    else if (slab.x > 0.0 || slab.y < 0.0) discard;",
    "    float tin = max(t0, ta), tout = min(t1, tb);",
    "    if (tin > tout) discard;",
    "    if (tin > t0) { cap = true; t = tin; }",
    "  }",
    "  if (t <= 0.0) discard;",
    "  vec3 p = t * dir;",
    "  vec3 n = cap ? (dot(clipN, dir) > 0.0 ? -clipN : clipN) : (p - vCenter) / vRadius;",
    "  vec3 l = normalize(vec3(0.35, 0.45, 1.0));",
    "  float diff = max(dot(n, l), 0.0);",
    "  float spec = cap ? 0.0 : pow(max(dot(reflect(-l, n), -dir), 0.0), 40.0);",
    "  vec3 base = cap ? vColor * 0.8 : vColor;",
    "  frag = vec4(base * (0.28 + 0.72 * diff) + vec3(0.25 * spec), 1.0);",
    "  vec4 clip = proj * vec4(p, 1.0);",
    "  gl_FragDepth = 0.5 * (clip.z / clip.w) + 0.5;",
    "}"
  ].join("\n");

  var LINE_VS = [
    "#version 300 es",
    "in vec3 pos; uniform mat4 view; uniform mat4 proj;",
    "void main() { gl_Position = proj * view * vec4(pos, 1.0); }"
  ].join("\n");
  var LINE_FS = [
    "#version 300 es", "precision mediump float; uniform vec3 col; out vec4 frag;",
    "void main() { frag = vec4(col, 1.0); }"
  ].join("\n");

  function compile(gl, type, src) {
    var s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error("shader: " + gl.getShaderInfoLog(s));
    return s;
  }
  function program(gl, vs, fs) {
    var p = gl.createProgram();
    gl.attachShader(p, compile(gl, gl.VERTEX_SHADER, vs));
    gl.attachShader(p, compile(gl, gl.FRAGMENT_SHADER, fs));
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error("program: " + gl.getProgramInfoLog(p));
    return p;
  }

  // ------------------------------------------------------------------ the viewer
  function Viewer(root, data) {
    var self = this;
    this.t0 = performance.now();
    this.root = root;
    this.data = data;
    this.frames = 0;
    this.firstFrameMs = null;
    this.drawnSpheres = 0;
    this.drawBox = true;
    this.realization = 0;
    this.field = data.initial_field || "species";
    this.clip = { on: false, axis: 2, lo: 0.0, hi: 1.0 };  // slab in box fractions
    this._home();
    this.canvas = root.querySelector("canvas");
    var gl = this.canvas.getContext("webgl2", { antialias: false, preserveDrawingBuffer: true });
    if (!gl) throw new Error("this browser has no WebGL2: the pack viewer needs it");
    this.gl = gl;
    this.sphereProg = program(gl, SPHERE_VS, SPHERE_FS);
    this.lineProg = program(gl, LINE_VS, LINE_FS);
    this.quadProg = program(gl, QUAD_VS, SPHERE_FS);
    this.maxPoint = gl.getParameter(gl.ALIASED_POINT_SIZE_RANGE)[1];
    this.forceQuads = false;
    this.path = "points";
    this.vao = gl.createVertexArray();
    gl.bindVertexArray(this.vao);
    var P = this.sphereProg;
    this.buf = {};
    function inst(name, size, type, norm) {
      var b = gl.createBuffer(), l = gl.getAttribLocation(P, name);
      gl.bindBuffer(gl.ARRAY_BUFFER, b);
      gl.enableVertexAttribArray(l);
      gl.vertexAttribPointer(l, size, type, norm, 0, 0);
      self.buf[name] = b;
    }
    inst("center", 3, gl.FLOAT, false);
    inst("radius", 1, gl.FLOAT, false);
    inst("color", 4, gl.UNSIGNED_BYTE, true);
    gl.bindVertexArray(null);
    // the quad path: a corner per vertex, the same sphere buffers per instance
    var Q = this.quadProg;
    this.quadVao = gl.createVertexArray();
    gl.bindVertexArray(this.quadVao);
    var corner = gl.createBuffer(), cl = gl.getAttribLocation(Q, "corner");
    gl.bindBuffer(gl.ARRAY_BUFFER, corner);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 1, -1, -1, 1, 1, 1]), gl.STATIC_DRAW);
    gl.enableVertexAttribArray(cl);
    gl.vertexAttribPointer(cl, 2, gl.FLOAT, false, 0, 0);
    [["center", 3, gl.FLOAT, false], ["radius", 1, gl.FLOAT, false], ["color", 4, gl.UNSIGNED_BYTE, true]].forEach(function (a) {
      var l = gl.getAttribLocation(Q, a[0]);
      gl.bindBuffer(gl.ARRAY_BUFFER, self.buf[a[0]]);
      gl.enableVertexAttribArray(l);
      gl.vertexAttribPointer(l, a[1], a[2], a[3], 0, 0);
      gl.vertexAttribDivisor(l, 1);
    });
    gl.bindVertexArray(null);
    this.lineVao = gl.createVertexArray();
    gl.bindVertexArray(this.lineVao);
    this.lineBuf = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, this.lineBuf);
    var ll = gl.getAttribLocation(this.lineProg, "pos");
    gl.enableVertexAttribArray(ll);
    gl.vertexAttribPointer(ll, 3, gl.FLOAT, false, 0, 0);
    gl.bindVertexArray(null);
    this.u = {}; this.uq = {};
    ["view", "proj", "clipOn", "clipN", "slab", "viewport", "maxPoint"].forEach(function (k) {
      self.u[k] = gl.getUniformLocation(P, k); self.uq[k] = gl.getUniformLocation(Q, k);
    });
    this.ul = {
      view: gl.getUniformLocation(this.lineProg, "view"), proj: gl.getUniformLocation(this.lineProg, "proj"),
      col: gl.getUniformLocation(this.lineProg, "col")
    };
    this._controls();
    this._mouse();
    this.setRealization(0, true);
    this._resize();
    window.addEventListener("resize", function () { self._resize(); self.render(); });
    this.render();
  }

  Viewer.prototype._q = function (sel) { return this.root.querySelector(sel); };

  /* The initial view: oblique for spheres, face-on for disks (2D packs). */
  Viewer.prototype._home = function () {
    var flat = this.data.realizations[0] && this.data.realizations[0].dim === 2;
    this.yaw = flat ? 0 : 0.6; this.pitch = flat ? 0 : 0.45; this.dist = null; this.pan = [0, 0, 0];
  };

  Viewer.prototype._controls = function () {
    var self = this, d = this.data;
    var rsel = this._q(".pp-real");
    if (rsel) {
      d.realizations.forEach(function (r, i) {
        var o = document.createElement("option"); o.value = i; o.textContent = r.label; rsel.appendChild(o);
      });
      rsel.addEventListener("change", function () { self.setRealization(+rsel.value); });
      if (d.realizations.length < 2) rsel.parentNode.style.display = "none";
    }
    var fsel = this._q(".pp-field");
    fsel.addEventListener("change", function () { self.setField(fsel.value); });
    var on = this._q(".pp-clip-on"), ax = this._q(".pp-clip-axis"), pos = this._q(".pp-clip-pos"),
      thick = this._q(".pp-clip-thick");
    function upd() {
      var c = +pos.value / 1000, w = +thick.value / 1000;
      self.setClip(on.checked, +ax.value, c - w / 2, c + w / 2);
    }
    [on, ax].forEach(function (e) { e.addEventListener("change", upd); });
    [pos, thick].forEach(function (e) { e.addEventListener("input", upd); });
    this._q(".pp-reset").addEventListener("click", function () {
      self._home(); self.render();
    });
    this._q(".pp-png").addEventListener("click", function () { self.savePNG(); });
  };

  Viewer.prototype._mouse = function () {
    var self = this, cv = this.canvas, last = null, button = 0;
    cv.addEventListener("contextmenu", function (e) { e.preventDefault(); });
    cv.addEventListener("pointerdown", function (e) {
      last = [e.clientX, e.clientY]; button = (e.button === 2 || e.shiftKey) ? 2 : 0;
      cv.setPointerCapture(e.pointerId);
      self.interacting = true;
    });
    cv.addEventListener("pointerup", function () { last = null; self.interacting = false; self.render(); });
    cv.addEventListener("pointermove", function (e) {
      if (!last) return;
      var dx = e.clientX - last[0], dy = e.clientY - last[1];
      last = [e.clientX, e.clientY];
      if (button === 2) {  // pan in the view plane
        var s = self.dist / cv.clientHeight, V = self.matrices().view;
        // camera right and up vectors in world coordinates: rows of the view rotation
        var right = [V[0], V[4], V[8]], up = [V[1], V[5], V[9]];
        for (var k = 0; k < 3; k++) self.pan[k] -= s * (dx * right[k] - dy * up[k]);
      } else {
        self.yaw += dx * 0.01;
        self.pitch = Math.max(-1.55, Math.min(1.55, self.pitch + dy * 0.01));
      }
      self.render();
    });
    cv.addEventListener("wheel", function (e) {
      e.preventDefault();
      self.dist *= Math.exp(0.0015 * e.deltaY);
      self.render();
    }, { passive: false });
  };

  /* While the mouse drags, large packs are drawn at half resolution (a quarter of the
   * pixels) so that orbiting stays fluid without a fast GPU; full resolution on release. */
  Viewer.prototype._resize = function () {
    var dpr = (window.devicePixelRatio || 1) * (this.interacting && this.n > 20000 ? 0.5 : 1), cv = this.canvas;
    var w = Math.max(1, Math.round(cv.clientWidth * dpr)), h = Math.max(1, Math.round(cv.clientHeight * dpr));
    if (cv.width !== w || cv.height !== h) { cv.width = w; cv.height = h; }
  };

  Viewer.prototype.setRealization = function (i, quiet) {
    var d = this.data, r = d.realizations[i];
    if (!r) throw new Error("no realization " + i);
    var gl = this.gl;
    this.realization = i;
    this.cur = r;
    if (!r._pos) {
      r._pos = decode(r.positions); r._rad = decode(r.radii);
      var m = 0; for (var q = 0; q < r._rad.length; q++) if (r._rad[q] > m) m = r._rad[q];
      r._rmax = m;
    }
    this.rmax = r._rmax;
    this.n = r.n;
    this.box = r.box;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buf.center);
    gl.bufferData(gl.ARRAY_BUFFER, r._pos, gl.STATIC_DRAW);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buf.radius);
    gl.bufferData(gl.ARRAY_BUFFER, r._rad, gl.STATIC_DRAW);
    var L = r.box, e = [];
    var cs = [[0, 0, 0], [L[0], 0, 0], [L[0], L[1], 0], [0, L[1], 0], [0, 0, L[2]], [L[0], 0, L[2]], [L[0], L[1], L[2]], [0, L[1], L[2]]];
    [[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4], [0, 4], [1, 5], [2, 6], [3, 7]].forEach(function (p) {
      e.push.apply(e, cs[p[0]]); e.push.apply(e, cs[p[1]]);
    });
    gl.bindBuffer(gl.ARRAY_BUFFER, this.lineBuf);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(e), gl.STATIC_DRAW);
    this._fillFields();
    var f = r.fields[this.field] ? this.field : Object.keys(r.fields)[0];
    this.setField(f, true);
    var info = this._q(".pp-info");
    if (info) info.textContent = r.label + ": N = " + r.n + ", box " + L.map(function (x) { return x.toPrecision(4); }).join(" \u00d7 ");
    var rsel = this._q(".pp-real");
    if (rsel) rsel.value = String(i);
    if (!quiet) this.render();
  };

  Viewer.prototype._fillFields = function () {
    var fsel = this._q(".pp-field"), r = this.cur, keep = fsel.value;
    fsel.innerHTML = "";
    Object.keys(r.fields).forEach(function (k) {
      var o = document.createElement("option"); o.value = k; o.textContent = r.fields[k].label || k; fsel.appendChild(o);
    });
    if (keep && r.fields[keep]) fsel.value = keep;
  };

  Viewer.prototype.setField = function (name, quiet) {
    var r = this.cur, f = r.fields[name];
    if (!f) throw new Error("unknown colour field '" + name + "'; allowed: " + Object.keys(r.fields).join(", "));
    if (!f._v) {
      if (f.derived !== undefined) {  // a coordinate of the centres: computed here, not stored
        var ax = f.derived, P = r._pos, w = new Float32Array(r.n), lo = Infinity, hi = -Infinity;
        for (var q = 0; q < r.n; q++) { w[q] = P[3 * q + ax]; lo = Math.min(lo, w[q]); hi = Math.max(hi, w[q]); }
        f._v = w; f.min = lo; f.max = hi;
      } else f._v = decode(f.values);
    }
    var v = f._v, n = r.n, col = new Uint8Array(4 * n), cm, i, k;
    var legend = this._q(".pp-legend");
    legend.innerHTML = "";
    if (f.kind === "category") {
      cm = this.data.colormaps[f.colormap || "category"];
      var nc = cm.length / 3;
      for (i = 0; i < n; i++) { k = (v[i] % nc) * 3; col[4 * i] = cm[k]; col[4 * i + 1] = cm[k + 1]; col[4 * i + 2] = cm[k + 2]; col[4 * i + 3] = 255; }
      (f.categories || []).forEach(function (lab, j) {
        var s = document.createElement("span"), kk = (j % nc) * 3;
        s.className = "pp-swatch";
        s.innerHTML = "<i style='background:rgb(" + cm[kk] + "," + cm[kk + 1] + "," + cm[kk + 2] + ")'></i>";
        s.appendChild(document.createTextNode(lab));
        legend.appendChild(s);
      });
    } else {
      cm = this.data.colormaps[f.colormap || "viridis"];
      var m = cm.length / 3, lo = f.min, hi = f.max, span = hi > lo ? hi - lo : 1;
      for (i = 0; i < n; i++) {
        k = Math.max(0, Math.min(m - 1, Math.round((v[i] - lo) / span * (m - 1)))) * 3;
        col[4 * i] = cm[k]; col[4 * i + 1] = cm[k + 1]; col[4 * i + 2] = cm[k + 2]; col[4 * i + 3] = 255;
      }
      var stops = [];
      for (i = 0; i <= 8; i++) { k = Math.round(i / 8 * (m - 1)) * 3; stops.push("rgb(" + cm[k] + "," + cm[k + 1] + "," + cm[k + 2] + ")"); }
      var bar = document.createElement("span");
      bar.className = "pp-bar";
      bar.style.background = "linear-gradient(to right," + stops.join(",") + ")";
      var a = document.createElement("span"); a.textContent = fmt(lo);
      var z = document.createElement("span"); z.textContent = fmt(hi) + (f.unit ? " " + f.unit : "");
      legend.appendChild(a); legend.appendChild(bar); legend.appendChild(z);
    }
    var gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buf.color);
    gl.bufferData(gl.ARRAY_BUFFER, col, gl.STATIC_DRAW);
    this.field = name;
    var fsel = this._q(".pp-field");
    if (fsel.value !== name) fsel.value = name;
    if (!quiet) this.render();
  };

  function fmt(x) { return Math.abs(x) >= 1e4 || (x !== 0 && Math.abs(x) < 1e-3) ? x.toExponential(3) : +x.toPrecision(4) + ""; }

  /* Clipping slab: keep lo <= x_axis / L_axis <= hi (fractions of the box along the axis). */
  Viewer.prototype.setClip = function (on, axis, lo, hi) {
    this.clip = { on: !!on, axis: axis | 0, lo: lo, hi: hi };
    var on_ = this._q(".pp-clip-on");
    if (on_ && on_.checked !== !!on) on_.checked = !!on;
    this.render();
  };

  Viewer.prototype.matrices = function () {
    var L = this.box, diag = Math.sqrt(L[0] * L[0] + L[1] * L[1] + L[2] * L[2]);
    if (this.dist === null) this.dist = 1.9 * diag;
    var cv = this.canvas, aspect = cv.width / cv.height;
    var target = [L[0] / 2 + this.pan[0], L[1] / 2 + this.pan[1], L[2] / 2 + this.pan[2]];
    var view = mul(translate(0, 0, -this.dist), mul(rotX(this.pitch), mul(rotY(-this.yaw), translate(-target[0], -target[1], -target[2]))));
    var near = Math.max(this.dist - diag, this.dist * 0.02), far = this.dist + diag * 1.5;
    return { view: view, proj: perspective(30 * Math.PI / 180, aspect, near, far) };
  };

  Viewer.prototype.render = function () {
    var gl = this.gl, self = this;
    if (this._pending) return;
    this._pending = true;
    requestAnimationFrame(function () { self._pending = false; self.draw(); });
  };

  Viewer.prototype.draw = function () {
    var gl = this.gl;
    this._resize();
    var M = this.matrices();
    gl.viewport(0, 0, this.canvas.width, this.canvas.height);
    var bg = this.data.background || [1, 1, 1];
    gl.clearColor(bg[0], bg[1], bg[2], 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    // point sprites unless the largest sphere may need a sprite larger than the GPU allows
    var L = this.box, diag = Math.sqrt(L[0] * L[0] + L[1] * L[1] + L[2] * L[2]);
    var near = Math.max(this.dist - 0.5 * diag - this.rmax, 0.05 * this.rmax);
    var need = 2.2 * this.rmax / near * M.proj[5] * this.canvas.height + 2;
    var quads = this.forceQuads || need > this.maxPoint;
    this.path = quads ? "quads" : "points";
    var prog = quads ? this.quadProg : this.sphereProg, U = quads ? this.uq : this.u;
    gl.useProgram(prog);
    gl.uniformMatrix4fv(U.view, false, M.view);
    gl.uniformMatrix4fv(U.proj, false, M.proj);
    gl.uniform2f(U.viewport, this.canvas.width, this.canvas.height);
    if (!quads) gl.uniform1f(U.maxPoint, this.maxPoint);
    var c = this.clip;
    gl.uniform1i(U.clipOn, c.on ? 1 : 0);
    // world plane n.x in [lo L, hi L] -> view space: n_v = R n, offset + (R n).t
    var n = [0, 0, 0]; n[c.axis] = 1;
    var V = M.view, nv = [V[0] * n[0] + V[4] * n[1] + V[8] * n[2], V[1] * n[0] + V[5] * n[1] + V[9] * n[2], V[2] * n[0] + V[6] * n[1] + V[10] * n[2]];
    var off = nv[0] * V[12] + nv[1] * V[13] + nv[2] * V[14];
    gl.uniform3fv(U.clipN, nv);
    gl.uniform2f(U.slab, c.lo * L[c.axis] + off, c.hi * L[c.axis] + off);
    if (quads) {
      gl.bindVertexArray(this.quadVao);
      gl.drawArraysInstanced(gl.TRIANGLE_STRIP, 0, 4, this.n);
    } else {
      gl.bindVertexArray(this.vao);
      gl.drawArrays(gl.POINTS, 0, this.n);
    }
    this.drawnSpheres = this.n;
    if (this.drawBox) {  // the periodic box outline
      gl.useProgram(this.lineProg);
      gl.uniformMatrix4fv(this.ul.view, false, M.view);
      gl.uniformMatrix4fv(this.ul.proj, false, M.proj);
      gl.uniform3f(this.ul.col, 0.25, 0.25, 0.25);
      gl.bindVertexArray(this.lineVao);
      gl.drawArrays(gl.LINES, 0, 24);
    }
    gl.bindVertexArray(null);
    this.frames += 1;
    if (this.firstFrameMs === null) {
      var px = new Uint8Array(4);
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);  // waits for the frame to finish
      this.firstFrameMs = performance.now();  // since the navigation started
      this.setupMs = this.firstFrameMs - this.t0;  // of which: decoding, shaders, first draw
    }
  };

  Viewer.prototype.toPNG = function () { this.draw(); return this.canvas.toDataURL("image/png"); };

  Viewer.prototype.savePNG = function () {
    var self = this;
    this.draw();
    this.canvas.toBlob(function (blob) {
      var a = document.createElement("a");
      a.href = URL.createObjectURL(blob);
      a.download = (self.data.name || "pack") + "_" + self.cur.label + ".png";
      document.body.appendChild(a); a.click(); a.remove();
      setTimeout(function () { URL.revokeObjectURL(a.href); }, 1000);
    }, "image/png");
  };

  function start() {
    window.polypackViewers = window.polypackViewers || [];
    var roots = document.querySelectorAll(".pp-viewer");
    for (var i = 0; i < roots.length; i++) {
      var root = roots[i];
      if (root._ppViewer) continue;
      var data = JSON.parse(root.querySelector("script.pp-data").textContent);
      var v = new Viewer(root, data);
      root._ppViewer = v;
      window.polypackViewers.push(v);
      window.polypackViewer = v;
    }
  }
  // each viewer block ends with a call of polypackStart(), so the viewer starts before the rest
  // of a long page (tables, figures) is parsed; DOMContentLoaded catches any other case
  window.polypackStart = start;
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
