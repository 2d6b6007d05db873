/* shellrepair's 3D view of a repaired mesh (WebGL; no library, no network).
 *
 * Each element of class "srv" holds one view: its payload inline (in a
 * JSON script element of class "srv-data") or in a script file
 * named by data-src, written beside the page, that sets
 * window.shellrepairViews[src]. A view starts when the page opens
 * (data-eager), when it scrolls into sight or on its "show now" button; at most MAX_LIVE views hold a WebGL context
 * at once (the oldest out of sight is released and starts again when seen).
 *
 * The element's data-state says where it is: "waiting", "loading",
 * "drawn" (data-drawn-ms: the page's clock when the first frame was
 * complete), "paused", "no-webgl" or "error".
 *
 * Shading: glTF's metallic-roughness model per vertex (base colour,
 * metallic, roughness from the payload): a GGX distribution, Smith-Schlick
 * visibility and Schlick's Fresnel for two lights fixed to the camera,
 * plus a sky-and-ground environment for the ambient and the reflection.
 */
(function () {
  'use strict';
  var MAX_LIVE = 6;
  var FOV_Y = 30 * Math.PI / 180;
  var CLEAR = [0.914, 0.906, 0.882];
  var live = [];

  // ------------------------------------------------------------------ math
  function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
  function add(a, b) { return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]; }
  function scale(a, s) { return [a[0] * s, a[1] * s, a[2] * s]; }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
  function norm(a) { var l = Math.sqrt(dot(a, a)); return l > 0 ? scale(a, 1 / l) : a; }
  function lookAt(eye, target, up) {          // column-major view matrix
    var z = norm(sub(eye, target)), x = norm(cross(up, z)), y = cross(z, x);
    return [x[0], y[0], z[0], 0, x[1], y[1], z[1], 0, x[2], y[2], z[2], 0,
            -dot(x, eye), -dot(y, eye), -dot(z, eye), 1];
  }
  function perspective(fovy, aspect, near, far) {
    var f = 1 / Math.tan(fovy / 2), nf = 1 / (near - far);
    return [f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1, 0, 0, 2 * far * near * nf, 0];
  }
  function mul(a, b) {                         // a * b, column-major 4x4
    var o = new Array(16);
    for (var c = 0; c < 4; c++) for (var r = 0; r < 4; r++) {
      var s = 0;
      for (var k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k];
      o[c * 4 + r] = s;
    }
    return o;
  }
  function bytes(b64) {
    var s = atob(b64), n = s.length, u = new Uint8Array(n);
    for (var i = 0; i < n; i++) u[i] = s.charCodeAt(i);
    return u;
  }

  // --------------------------------------------------------------- shaders
  var VS = [
    'attribute vec3 a_pos; attribute vec3 a_nrm; attribute vec3 a_col; attribute vec2 a_mr;',
    'uniform mat4 u_mvp; varying vec3 v_pos; varying vec3 v_nrm; varying vec3 v_col; varying vec2 v_mr;',
    'void main() { v_pos = a_pos; v_nrm = a_nrm; v_col = a_col; v_mr = a_mr;',
    '  gl_Position = u_mvp * vec4(a_pos, 1.0); }'].join('\n');
  var FS = [
    'precision highp float;',
    'varying vec3 v_pos; varying vec3 v_nrm; varying vec3 v_col; varying vec2 v_mr;',
    'uniform vec3 u_eye; uniform vec3 u_up; uniform vec3 u_key; uniform vec3 u_fill;',
    'uniform vec3 u_tint; uniform float u_tintAmt;',
    'const float PI = 3.14159265;',
    'vec3 env(vec3 d) {  // sky above, warm ground below',
    '  float t = clamp(0.5 + 0.5 * dot(d, u_up), 0.0, 1.0);',
    '  return mix(vec3(0.23, 0.21, 0.19), vec3(0.95, 0.97, 1.0), smoothstep(0.2, 0.8, t)); }',
    'vec3 light(vec3 n, vec3 v, vec3 l, vec3 diff, vec3 f0, float a) {',
    '  float ndl = max(dot(n, l), 0.0); if (ndl <= 0.0) return vec3(0.0);',
    '  vec3 h = normalize(l + v); float ndh = max(dot(n, h), 0.0), ndv = max(dot(n, v), 1e-4);',
    '  float a2 = a * a, q = ndh * ndh * (a2 - 1.0) + 1.0;',
    '  float D = a2 / (PI * q * q);                                  // GGX distribution',
    '  float k = 0.5 * a;',
    '  float G = 1.0 / ((ndl * (1.0 - k) + k) * (ndv * (1.0 - k) + k)); // Smith-Schlick, over 4 ndl ndv',
    '  vec3 F = f0 + (1.0 - f0) * pow(1.0 - max(dot(v, h), 0.0), 5.0); // Schlick',
    '  return ndl * ((1.0 - F) * diff / PI + 0.25 * D * G * F); }',
    'void main() {',
    '  vec3 n = normalize(v_nrm), v = normalize(u_eye - v_pos);',
    '  if (dot(n, v) < 0.0) n = -n;                 // an open scan shows its inside too',
    '  vec3 base = pow(v_col, vec3(2.2)); float metal = v_mr.x;',
    '  float rough = clamp(v_mr.y, 0.05, 1.0), a = rough * rough;',
    '  vec3 f0 = mix(vec3(0.04), base, metal), diff = base * (1.0 - metal);',
    '  vec3 c = 2.4 * light(n, v, u_key, diff, f0, a) + 0.7 * light(n, v, u_fill, diff, f0, a);',
    '  float ndv = max(dot(n, v), 0.0);',
    '  vec3 Fe = f0 + (max(vec3(1.0 - rough), f0) - f0) * pow(1.0 - ndv, 5.0);',
    '  vec3 r = reflect(-v, n);',
    '  c += 0.3 * diff * env(n) + Fe * mix(env(r), env(n), a) * 0.7;',
    '  c = c / (1.0 + 0.35 * c);                      // soft shoulder',
    '  c = mix(c, u_tint * (0.35 + 0.65 * max(dot(n, u_key), 0.0)), u_tintAmt);',
    '  gl_FragColor = vec4(pow(clamp(c, 0.0, 1.0), vec3(1.0 / 2.2)), 1.0); }'].join('\n');
  var LVS = 'attribute vec3 a_pos; uniform mat4 u_mvp; void main() { gl_Position = u_mvp * vec4(a_pos, 1.0); }';
  var LFS = 'precision mediump float; uniform vec3 u_color; void main() { gl_FragColor = vec4(u_color, 1.0); }';

  function program(gl, vs, fs) {
    function sh(type, src) {
      var s = gl.createShader(type);
      gl.shaderSource(s, src); gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
      return s;
    }
    var p = gl.createProgram();
    gl.attachShader(p, sh(gl.VERTEX_SHADER, vs)); gl.attachShader(p, sh(gl.FRAGMENT_SHADER, fs));
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
    var info = {p: p, a: {}, u: {}};
    for (var i = 0, n = gl.getProgramParameter(p, gl.ACTIVE_ATTRIBUTES); i < n; i++) {
      var at = gl.getActiveAttrib(p, i).name; info.a[at] = gl.getAttribLocation(p, at);
    }
    for (i = 0, n = gl.getProgramParameter(p, gl.ACTIVE_UNIFORMS); i < n; i++) {
      var un = gl.getActiveUniform(p, i).name; info.u[un] = gl.getUniformLocation(p, un);
    }
    return info;
  }

  // ------------------------------------------------------------- the mesh
  function decode(d) {
    var lo = d.lo, hi = d.hi, span = [], ctr = [];
    for (var k = 0; k < 3; k++) { span.push(hi[k] > lo[k] ? hi[k] - lo[k] : 1); ctr.push(0.5 * (lo[k] + hi[k])); }
    function positions(b64) {                 // about the box's centre, float32
      var b = bytes(b64), q = new Uint16Array(b.buffer, 0, b.length >> 1), p = new Float32Array(q.length);
      for (var i = 0; i < q.length; i++) { var c = i % 3; p[i] = lo[c] + q[i] / 65535 * span[c] - ctr[c]; }
      return p;
    }
    var P = positions(d.positions), ib = bytes(d.index);
    var I = d.index_bytes === 4 ? new Uint32Array(ib.buffer, 0, ib.length >> 2) : new Uint16Array(ib.buffer, 0, ib.length >> 1);
    var N = new Float32Array(P.length);        // area-weighted vertex normals
    for (var f = 0; f < I.length; f += 3) {
      var a = I[f] * 3, b = I[f + 1] * 3, c2 = I[f + 2] * 3;
      var ux = P[b] - P[a], uy = P[b + 1] - P[a + 1], uz = P[b + 2] - P[a + 2];
      var vx = P[c2] - P[a], vy = P[c2 + 1] - P[a + 1], vz = P[c2 + 2] - P[a + 2];
      var nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
      N[a] += nx; N[a + 1] += ny; N[a + 2] += nz; N[b] += nx; N[b + 1] += ny; N[b + 2] += nz;
      N[c2] += nx; N[c2 + 1] += ny; N[c2 + 2] += nz;
    }
    var R = 0;
    for (var i = 0; i < P.length; i += 3) {
      var l = Math.sqrt(N[i] * N[i] + N[i + 1] * N[i + 1] + N[i + 2] * N[i + 2]) || 1;
      N[i] /= l; N[i + 1] /= l; N[i + 2] /= l;
      R = Math.max(R, P[i] * P[i] + P[i + 1] * P[i + 1] + P[i + 2] * P[i + 2]);
    }
    return {P: P, N: N, I: I, C: bytes(d.color), MR: bytes(d.mr), E: positions(d.edges),
            centre: ctr, radius: Math.sqrt(R) || 1};
  }

  // ------------------------------------------------------------- the view
  function context(canvas, antialias) {
    // preserveDrawingBuffer: the page's pixels can be read back (tests, screenshots)
    var o = {antialias: antialias, preserveDrawingBuffer: true};
    return canvas.getContext('webgl2', o) || canvas.getContext('webgl', o);
  }
  function software(gl) {
    var info = gl.getExtension('WEBGL_debug_renderer_info');
    var name = info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
    return /swiftshader|llvmpipe|softpipe|software/i.test(String(name));
  }
  function View(el, d) {
    this.el = el; this.d = d; this.tint = true;
    el.textContent = '';
    var bar = document.createElement('div'); bar.className = 'srv-bar';
    var canvas = document.createElement('canvas');
    var info = document.createElement('div'); info.className = 'srv-info';
    el.appendChild(canvas); el.appendChild(bar); el.appendChild(info);
    var gl = context(canvas, false);
    if (gl && !software(gl)) {
      // a GPU antialiases at little cost: a new canvas with it. A software renderer (no GPU)
      // keeps the first, which draws a large mesh's first frame in half the time
      var ext = gl.getExtension('WEBGL_lose_context');
      if (ext) ext.loseContext();
      var smooth = document.createElement('canvas');
      el.replaceChild(smooth, canvas);
      canvas = smooth;
      gl = context(canvas, true);
    }
    this.canvas = canvas;
    if (!gl) throw {noWebGL: true};
    this.gl = gl;
    this.uint = d.index_bytes === 4;
    var gl2 = typeof WebGL2RenderingContext !== 'undefined' && gl instanceof WebGL2RenderingContext;
    if (this.uint && !gl2 && !gl.getExtension('OES_element_index_uint')) throw {noWebGL: true};
    var m = this.mesh = decode(d);
    this.prog = program(gl, VS, FS); this.lprog = program(gl, LVS, LFS);
    function buf(target, data) { var b = gl.createBuffer(); gl.bindBuffer(target, b); gl.bufferData(target, data, gl.STATIC_DRAW); return b; }
    this.bP = buf(gl.ARRAY_BUFFER, m.P); this.bN = buf(gl.ARRAY_BUFFER, m.N);
    this.bC = buf(gl.ARRAY_BUFFER, m.C); this.bMR = buf(gl.ARRAY_BUFFER, m.MR);
    this.bE = buf(gl.ARRAY_BUFFER, m.E); this.bI = buf(gl.ELEMENT_ARRAY_BUFFER, m.I);
    this.up = norm(d.up);
    var ref = Math.abs(this.up[2]) < 0.9 ? [0, 0, 1] : [1, 0, 0];
    this.ax = norm(sub(ref, scale(this.up, dot(ref, this.up)))); this.bx = cross(this.up, this.ax);
    this.buildBar(bar);
    info.textContent = d.faces_shown < d.faces_total ?
      d.faces_shown.toLocaleString('en') + ' of ' + d.faces_total.toLocaleString('en') + ' faces shown (a lighter copy for the page)' :
      d.faces_total.toLocaleString('en') + ' faces';
    this.reset();
    this.bindInput();
    var self = this;
    canvas.addEventListener('webglcontextlost', function (e) {
      e.preventDefault();
      if (!self.gl) return;                       // released here (pause): not the browser's doing
      self.lost = true; pause(self, 'the browser took its WebGL context back');
    });
  }
  View.prototype.buildBar = function (bar) {
    var self = this, d = this.d;
    function button(text, title, fn) {
      var b = document.createElement('button'); b.type = 'button'; b.textContent = text; b.title = title;
      b.addEventListener('click', fn); bar.appendChild(b); return b;
    }
    button('Reset view', 'back to the first view', function () { self.reset(); self.draw(); }).className = 'srv-reset';
    if (d.regions.length) {
      var lab = document.createElement('label'), cb = document.createElement('input');
      cb.type = 'checkbox'; cb.checked = true; cb.className = 'srv-tint';
      cb.addEventListener('change', function () { self.tint = cb.checked; self.draw(); });
      lab.appendChild(cb); lab.appendChild(document.createTextNode(' tint filled faces'));
      bar.insertBefore(lab, bar.firstChild);
      d.regions.forEach(function (r, k) {
        button('Fill ' + (k + 1), 'frame filled region ' + (k + 1) + ' (' + r.faces + ' faces)',
               function () { self.frame(k); self.draw(); }).className = 'srv-region';
      });
    }
    if (d.open_edges) {
      var s = document.createElement('span');
      s.textContent = d.open_edges + ' edges left open (blue)';
      bar.appendChild(s);
    }
  };
  View.prototype.setDir = function (v) {      // azimuth and elevation of a direction from the target
    v = norm(v);
    this.el_ = Math.asin(Math.max(-1, Math.min(1, dot(v, this.up))));
    this.az = Math.atan2(dot(v, this.bx), dot(v, this.ax));
  };
  View.prototype.reset = function () {
    this.target = [0, 0, 0];
    this.setDir(this.d.view);
    var half = Math.min(FOV_Y / 2, Math.atan(Math.tan(FOV_Y / 2) * this.aspect()));
    this.dist = 1.02 * this.mesh.radius / Math.sin(half);
  };
  View.prototype.frame = function (k) {
    var r = this.d.regions[k], c = this.mesh.centre;
    this.target = sub(r.centre, c);
    if (r.normal) this.setDir(r.normal);
    this.el_ = Math.max(-1.3, Math.min(1.3, this.el_));
    this.dist = Math.max(2.2 * r.radius, 0.02 * this.mesh.radius) / Math.sin(FOV_Y / 2);
  };
  View.prototype.aspect = function () {
    return (this.canvas.clientWidth || 4) / (this.canvas.clientHeight || 3);
  };
  View.prototype.eye = function () {
    var ce = Math.cos(this.el_);
    var dir = add(add(scale(this.ax, ce * Math.cos(this.az)), scale(this.bx, ce * Math.sin(this.az))), scale(this.up, Math.sin(this.el_)));
    return add(this.target, scale(dir, this.dist));
  };
  View.prototype.resize = function () {
    var dpr = Math.min(window.devicePixelRatio || 1, 2), c = this.canvas;
    var w = Math.max(1, Math.round(c.clientWidth * dpr)), h = Math.max(1, Math.round(c.clientHeight * dpr));
    if (c.width !== w || c.height !== h) { c.width = w; c.height = h; }
  };
  View.prototype.request = function () {
    var self = this;
    if (this.pending) return;
    this.pending = true;
    requestAnimationFrame(function () { self.pending = false; self.draw(); });
  };
  View.prototype.draw = function () {
    if (this.lost || !this.gl) return;
    var gl = this.gl, m = this.mesh, d = this.d, p = this.prog, lp = this.lprog;
    this.resize();
    var W = this.canvas.width, H = this.canvas.height, eye = this.eye();
    var toC = Math.sqrt(dot(eye, eye)), R = m.radius;
    var far = toC + 1.5 * R, near = Math.max(far * 1e-4, toC - 1.5 * R);
    var vp = mul(perspective(FOV_Y, W / H, near, far), lookAt(eye, this.target, this.up));
    // lights fixed to the camera: a key from the upper left, a fill from the right
    var back = norm(sub(eye, this.target)), right = norm(cross(this.up, back)), up = cross(back, right);
    var key = norm(add(add(scale(right, -0.45), scale(up, 0.6)), scale(back, 0.65)));
    var fill = norm(add(add(scale(right, 0.7), scale(up, -0.1)), scale(back, 0.7)));
    gl.viewport(0, 0, W, H);
    gl.clearColor(CLEAR[0], CLEAR[1], CLEAR[2], 1); gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    gl.useProgram(p.p);
    function attr(prog, name, b, size, type, normalized) {
      var loc = prog.a[name]; if (loc === undefined) return;
      gl.bindBuffer(gl.ARRAY_BUFFER, b); gl.enableVertexAttribArray(loc);
      gl.vertexAttribPointer(loc, size, type, normalized, 0, 0);
    }
    attr(p, 'a_pos', this.bP, 3, gl.FLOAT, false); attr(p, 'a_nrm', this.bN, 3, gl.FLOAT, false);
    attr(p, 'a_col', this.bC, 3, gl.UNSIGNED_BYTE, true); attr(p, 'a_mr', this.bMR, 2, gl.UNSIGNED_BYTE, true);
    gl.uniformMatrix4fv(p.u.u_mvp, false, new Float32Array(vp));
    gl.uniform3fv(p.u.u_eye, eye); gl.uniform3fv(p.u.u_up, this.up);
    gl.uniform3fv(p.u.u_key, key); gl.uniform3fv(p.u.u_fill, fill);
    gl.uniform3fv(p.u.u_tint, d.tint.map(function (x) { return x / 255; }));
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, this.bI);
    var type = this.uint ? gl.UNSIGNED_INT : gl.UNSIGNED_SHORT, step = this.uint ? 4 : 2;
    gl.enable(gl.POLYGON_OFFSET_FILL); gl.polygonOffset(1, 1);   // the open edges stay in front of their faces
    gl.uniform1f(p.u.u_tintAmt, 0);
    if (d.scan_faces) gl.drawElements(gl.TRIANGLES, 3 * d.scan_faces, type, 0);
    var nf = d.faces_shown - d.scan_faces;
    gl.uniform1f(p.u.u_tintAmt, this.tint ? 0.6 : 0);
    if (nf) gl.drawElements(gl.TRIANGLES, 3 * nf, type, 3 * d.scan_faces * step);
    gl.disable(gl.POLYGON_OFFSET_FILL);
    for (var k in p.a) gl.disableVertexAttribArray(p.a[k]);
    if (d.open_edges) {
      gl.useProgram(lp.p);
      attr(lp, 'a_pos', this.bE, 3, gl.FLOAT, false);
      gl.uniformMatrix4fv(lp.u.u_mvp, false, new Float32Array(vp));
      gl.uniform3fv(lp.u.u_color, d.edge_color.map(function (x) { return x / 255; }));
      gl.drawArrays(gl.LINES, 0, 2 * d.open_edges);
      gl.disableVertexAttribArray(lp.a.a_pos);
    }
    if (this.el.dataset.state !== 'drawn') {
      var px = new Uint8Array(4);
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);   // waits for the frame to be complete
      this.el.dataset.drawnMs = String(Math.round(performance.now()));
      this.el.dataset.state = 'drawn';
    }
  };
  View.prototype.bindInput = function () {
    var self = this, c = this.canvas, pts = {}, last = null;
    function pan(dx, dy) {
      var px = 2 * self.dist * Math.tan(FOV_Y / 2) / (c.clientHeight || 1);
      var eye = self.eye(), back = norm(sub(eye, self.target)), right = norm(cross(self.up, back)), up = cross(back, right);
      self.target = add(self.target, add(scale(right, -dx * px), scale(up, dy * px)));
    }
    function zoom(f) { self.dist = Math.max(1e-3 * self.mesh.radius, Math.min(20 * self.mesh.radius / Math.sin(FOV_Y / 2), self.dist * f)); }
    function spread() {
      var k = Object.keys(pts); if (k.length < 2) return null;
      var a = pts[k[0]], b = pts[k[1]];
      return {d: Math.hypot(a.x - b.x, a.y - b.y), x: (a.x + b.x) / 2, y: (a.y + b.y) / 2};
    }
    c.addEventListener('contextmenu', function (e) { e.preventDefault(); });
    c.addEventListener('pointerdown', function (e) {
      c.setPointerCapture(e.pointerId);
      pts[e.pointerId] = {x: e.clientX, y: e.clientY, pan: e.button === 2 || e.button === 1 || e.shiftKey};
      last = spread();
    });
    c.addEventListener('pointermove', function (e) {
      var p = pts[e.pointerId]; if (!p) return;
      var dx = e.clientX - p.x, dy = e.clientY - p.y;
      p.x = e.clientX; p.y = e.clientY;
      var s = spread();
      if (s && last) {                       // two fingers: pinch to zoom, move to pan
        if (s.d > 0 && last.d > 0) zoom(last.d / s.d);
        pan(s.x - last.x, s.y - last.y);
        last = s;
      } else if (p.pan) {
        pan(dx, dy);
      } else {
        self.az -= dx * 0.008;
        self.el_ = Math.max(-1.55, Math.min(1.55, self.el_ + dy * 0.008));
      }
      self.request();
    });
    function up(e) { delete pts[e.pointerId]; last = spread(); }
    c.addEventListener('pointerup', up); c.addEventListener('pointercancel', up);
    c.addEventListener('wheel', function (e) {
      e.preventDefault();
      zoom(Math.exp(0.0015 * (e.deltaMode === 1 ? 16 : 1) * e.deltaY)); self.request();
    }, {passive: false});
    c.addEventListener('dblclick', function () { self.reset(); self.draw(); });
    window.addEventListener('resize', function () { self.request(); });
  };

  // ------------------------------------------------------------ lifecycle
  function message(el, text, state) {
    el.dataset.state = state;
    var m = el.querySelector('.srv-msg');
    if (!m) { m = document.createElement('div'); m.className = 'srv-msg'; el.appendChild(m); }
    m.textContent = text;
    return m;
  }
  function pause(view, why) {
    var i = live.indexOf(view); if (i >= 0) live.splice(i, 1);
    var gl = view.gl, ext = gl && !view.lost && gl.getExtension('WEBGL_lose_context');
    view.gl = null;
    if (ext) ext.loseContext();
    var el = view.el; el.textContent = ''; el.view = null;
    var m = message(el, '3D view paused (' + why + '): ', 'paused');
    var b = document.createElement('button'); b.type = 'button'; b.textContent = 'show again';
    b.addEventListener('click', function () { start(el); }); m.appendChild(b);
  }
  function payloadOf(el, done) {
    if (el.payload) { done(el.payload); return; }          // read before: the view was paused
    var inline = el.querySelector('script.srv-data');
    if (inline) { done(el.payload = JSON.parse(inline.textContent)); return; }
    var src = el.dataset.src, reg = window.shellrepairViews = window.shellrepairViews || {};
    if (reg[src]) { done(reg[src]); return; }
    var s = document.createElement('script');
    s.src = src;
    s.onload = function () { if (reg[src]) done(reg[src]); else message(el, 'The 3D view\'s data is missing (' + src + ').', 'error'); };
    s.onerror = function () { message(el, 'The 3D view\'s data could not be read (' + src + ').', 'error'); };
    document.head.appendChild(s);
  }
  function start(el) {
    if (el.view || el.dataset.state === 'loading') return;
    message(el, 'loading the 3D view...', 'loading');
    payloadOf(el, function (d) {
      try {
        if (d.version !== 1) throw new Error('unknown view data version ' + d.version);
        while (live.length >= MAX_LIVE) {
          var old = live.filter(function (v) { return !v.visible; })[0] || live[0];
          pause(old, 'too many views open at once');
        }
        var v = new View(el, d);
        v.visible = true;
        el.view = v; live.push(v);
        v.draw();
      } catch (e) {
        if (e && e.noWebGL) message(el, 'This browser has no WebGL: the 3D view cannot be shown (the picture above shows the repair).', 'no-webgl');
        else { message(el, 'The 3D view failed: ' + (e && e.message || e), 'error'); if (window.console) console.warn(e); }
      }
    });
  }
  function init() {
    var els = document.querySelectorAll('.srv');
    var io = 'IntersectionObserver' in window ? new IntersectionObserver(function (entries) {
      entries.forEach(function (en) {
        var el = en.target;
        if (el.view) el.view.visible = en.isIntersecting;
        if (en.isIntersecting && !el.view && el.dataset.state !== 'paused') start(el);
      });
    }, {rootMargin: '200px'}) : null;
    Array.prototype.forEach.call(els, function (el) {
      el.dataset.state = 'waiting';
      var b = el.querySelector('.srv-start');
      if (b) b.addEventListener('click', function () { start(el); });
      if (io) io.observe(el);
      if (!io || el.dataset.eager) start(el);
    });
  }
  if (document.readyState === 'loading') document.addEventListener('DOMContentLoaded', init); else init();
})();
