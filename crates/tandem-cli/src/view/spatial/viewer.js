// tandem 3-D viewer: plain WebGL 1, no library, no network. Reads the scene JSON embedded in
// the page (see crates/tandem-cli/src/view/spatial/mod.rs for the format) and plays it.
// World frame: z up, metres. Test hooks: window.tandemViewer = { seek, play, pause, frames, ready }.
(function () {
  'use strict';

  var S = JSON.parse(document.getElementById('scene-data').textContent);
  var N = S.times.length;
  var api = {
    ready: false,
    frames: N,
    duration: N > 0 ? S.times[N - 1] - S.times[0] : 0,
    seek: seek,
    play: play,
    pause: pause,
    time: function () { return cur; },
    setView: setView,
    armScreenBox: armScreenBox
  };
  window.tandemViewer = api;

  // ---------------------------------------------------------------------------------------
  // Colours (matplotlib tab10, as the figures and snapshots).
  var ARM_COLOURS = [[148, 103, 189], [188, 189, 34], [127, 127, 127], [227, 119, 194]];
  var C = {
    box: [140, 86, 75], desired: [255, 127, 14], traced: [31, 119, 180], joint: [70, 70, 74],
    stick: [46, 160, 67], slip: [255, 152, 0], separated: [150, 150, 150],
    base: [110, 110, 116], force: [200, 20, 150], torque: [0, 128, 128],
    x: [214, 39, 40], y: [44, 160, 44], z: [40, 70, 235], grid: [190, 196, 205], grid10: [160, 166, 176]
  };
  function rgb(c) { return [c[0] / 255, c[1] / 255, c[2] / 255]; }
  function css(c) { return 'rgb(' + c[0] + ',' + c[1] + ',' + c[2] + ')'; }

  // ---------------------------------------------------------------------------------------
  // Small vector / matrix helpers (column-major 4 × 4 as WebGL expects).
  function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
  function add(a, b) { return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]; }
  function scl(a, s) { return [a[0] * s, a[1] * s, a[2] * s]; }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
  function norm(a) { return Math.sqrt(dot(a, a)); }
  function unit(a) { var n = norm(a); return n > 0 ? scl(a, 1 / n) : [0, 0, 1]; }
  function lerp(a, b, s) { return [a[0] + (b[0] - a[0]) * s, a[1] + (b[1] - a[1]) * s, a[2] + (b[2] - a[2]) * s]; }
  function finite3(p) { return p && isFinite(p[0]) && isFinite(p[1]) && isFinite(p[2]) && p[0] !== null && p[1] !== null && p[2] !== null; }

  function mul4(a, b) {
    var o = new Float32Array(16);
    for (var c = 0; c < 4; c++) {
      for (var r = 0; r < 4; r++) {
        var s = 0;
        for (var k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k];
        o[c * 4 + r] = s;
      }
    }
    return o;
  }
  function perspective(fovy, aspect, near, far) {
    var f = 1 / Math.tan(fovy / 2), nf = 1 / (near - far);
    return new Float32Array([f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1, 0, 0, 2 * far * near * nf, 0]);
  }
  function lookAt(eye, target, up) {
    var f = unit(sub(target, eye));
    var s = unit(cross(f, up));
    var u = cross(s, f);
    return new Float32Array([
      s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0,
      -dot(s, eye), -dot(u, eye), dot(f, eye), 1]);
  }
  // Model matrix with columns ex, ey, ez (orthogonal, scaled) and origin o, and its normal
  // matrix (inverse transpose of the 3 × 3 part: columns e / |e|²).
  function basis(o, ex, ey, ez) {
    var m = new Float32Array([ex[0], ex[1], ex[2], 0, ey[0], ey[1], ey[2], 0, ez[0], ez[1], ez[2], 0, o[0], o[1], o[2], 1]);
    var n = new Float32Array(9), es = [ex, ey, ez];
    for (var i = 0; i < 3; i++) {
      var d = dot(es[i], es[i]) || 1;
      n[i * 3] = es[i][0] / d; n[i * 3 + 1] = es[i][1] / d; n[i * 3 + 2] = es[i][2] / d;
    }
    return { m: m, n: n };
  }
  // Rotate v by the unit quaternion q = (w, x, y, z).
  function qrot(q, v) {
    var w = q[0], u = [q[1], q[2], q[3]];
    var c1 = cross(u, v), c2 = cross(u, c1);
    return [v[0] + 2 * (w * c1[0] + c2[0]), v[1] + 2 * (w * c1[1] + c2[1]), v[2] + 2 * (w * c1[2] + c2[2])];
  }
  function qnlerp(a, b, s) {
    var d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3], sg = d < 0 ? -1 : 1;
    var q = [0, 1, 2, 3].map(function (i) { return a[i] + (sg * b[i] - a[i]) * s; });
    var n = Math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]) || 1;
    return q.map(function (x) { return x / n; });
  }
  // Two unit vectors perpendicular to the unit vector d.
  function perp(d) {
    var a = Math.abs(d[2]) < 0.9 ? [0, 0, 1] : [1, 0, 0];
    var e1 = unit(cross(d, a));
    return [e1, cross(d, e1)];
  }

  // ---------------------------------------------------------------------------------------
  // Frames: validity (the Rust side marks frames with non-finite values), time lookup.
  var valid = (S.valid || []).slice();
  var nValid = 0, lastValid = new Array(N), firstValid = -1;
  for (var k = 0; k < N; k++) {
    if (valid[k]) { nValid++; if (firstValid < 0) firstValid = k; }
    lastValid[k] = valid[k] ? k : (k > 0 ? lastValid[k - 1] : -1);
  }
  var t0 = N > 0 ? S.times[0] : 0, tEnd = N > 0 ? S.times[N - 1] : 0;

  // Frame index pair (k, s) with times[k] ≤ t < times[k+1], s the interpolation share;
  // falls back to the last valid frame (or the first) when a neighbour is invalid.
  function frameAt(t) {
    if (N === 0 || firstValid < 0) return null;
    var lo = 0, hi = N - 1;
    if (t <= S.times[0]) hi = 0;
    else if (t >= S.times[N - 1]) lo = N - 1;
    else {
      while (hi - lo > 1) { var mid = (lo + hi) >> 1; if (S.times[mid] <= t) lo = mid; else hi = mid; }
    }
    var k = lo;
    if (hi > lo && valid[lo] && valid[hi]) {
      var dt = S.times[hi] - S.times[lo];
      return { k: lo, k2: hi, s: dt > 0 ? (t - S.times[lo]) / dt : 0, skipped: false };
    }
    var j = lastValid[k] >= 0 ? lastValid[k] : firstValid;
    return { k: j, k2: j, s: 0, skipped: j !== k };
  }
  function poseAt(arr, f) { // arr[k] = [x, y, z, w, qx, qy, qz]
    var a = arr[f.k], b = arr[f.k2];
    if (f.k2 === f.k) return { p: [a[0], a[1], a[2]], q: [a[3], a[4], a[5], a[6]] };
    return { p: lerp(a, b, f.s), q: qnlerp([a[3], a[4], a[5], a[6]], [b[3], b[4], b[5], b[6]], f.s) };
  }

  // ---------------------------------------------------------------------------------------
  // Scene extent (finite points of every frame) for the camera and the table grid.
  var lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  function grow(p) { if (finite3(p)) for (var i = 0; i < 3; i++) { lo[i] = Math.min(lo[i], p[i]); hi[i] = Math.max(hi[i], p[i]); } }
  S.arms.forEach(function (a) {
    grow(a.base);
    for (var k = 0; k < N; k++) {
      if (!valid[k]) continue;
      a.joints[k].forEach(grow);
      grow(a.tool[k]);
    }
  });
  for (var k2 = 0; k2 < N; k2++) if (valid[k2]) grow(S.object[k2]);
  S.desired.forEach(grow);
  if (!(lo[0] <= hi[0])) { lo = [-0.5, -0.5, 0]; hi = [0.5, 0.5, 0.5]; }
  grow([lo[0], lo[1], 0]);
  var centre = scl(add(lo, hi), 0.5);
  var radius = Math.max(0.25, 0.5 * norm(sub(hi, lo)));

  // ---------------------------------------------------------------------------------------
  // Wrench arrow scales: the largest force (torque) over the run is drawn 0.25 m long, rounded
  // to a 1-2-5 value per 0.1 m shown in the HUD.
  function nice(x) {
    if (!(x > 0) || !isFinite(x)) return 1;
    var e = Math.pow(10, Math.floor(Math.log10(x))), m = x / e;
    return (m <= 1 ? 1 : m <= 2 ? 2 : m <= 5 ? 5 : 10) * e;
  }
  var fMax = 0, tMax = 0, hasWrench = S.wrenches && S.wrenches.length > 0;
  if (hasWrench) {
    S.wrenches.forEach(function (fr) {
      (fr || []).forEach(function (w) {
        if (!w) return;
        var f = norm([w[0], w[1], w[2]]), t = norm([w[3], w[4], w[5]]);
        if (isFinite(f) && w[0] !== null) fMax = Math.max(fMax, f);
        if (isFinite(t) && w[3] !== null) tMax = Math.max(tMax, t);
      });
    });
  }
  var fPer01 = nice(fMax / 2.5), tPer01 = nice(tMax / 2.5); // N (N m) per 0.1 m of arrow

  // ---------------------------------------------------------------------------------------
  // WebGL set-up.
  var canvas = document.getElementById('gl');
  var gl = canvas.getContext('webgl', { antialias: true, preserveDrawingBuffer: true, alpha: false }) ||
    canvas.getContext('experimental-webgl', { antialias: true, preserveDrawingBuffer: true, alpha: false });
  var hud = document.getElementById('hud');
  if (!gl) {
    hud.innerHTML = '<div class="warn">This browser offers no WebGL: the 3-D view cannot be drawn.</div>';
    console.error('tandem viewer: WebGL is not available');
    return;
  }

  function shader(type, src) {
    var s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error('shader: ' + gl.getShaderInfoLog(s));
    return s;
  }
  function program(vs, fs, attrs, unis) {
    var p = gl.createProgram();
    gl.attachShader(p, shader(gl.VERTEX_SHADER, vs));
    gl.attachShader(p, shader(gl.FRAGMENT_SHADER, fs));
    attrs.forEach(function (a, i) { gl.bindAttribLocation(p, i, a); });
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error('link: ' + gl.getProgramInfoLog(p));
    var u = {};
    unis.forEach(function (n) { u[n] = gl.getUniformLocation(p, n); });
    return { p: p, u: u };
  }

  // Shaded meshes: two directional lights fixed to the camera plus ambient and a little specular.
  var meshProg = program(
    'attribute vec3 aPos; attribute vec3 aNor; uniform mat4 uVP; uniform mat4 uModel; uniform mat3 uNormal;' +
    'varying vec3 vN; varying vec3 vW;' +
    'void main() { vec4 w = uModel * vec4(aPos, 1.0); vW = w.xyz; vN = uNormal * aNor; gl_Position = uVP * w; }',
    'precision mediump float; uniform vec3 uColor; uniform float uAlpha; uniform vec3 uEye; uniform vec3 uL1; uniform vec3 uL2;' +
    'varying vec3 vN; varying vec3 vW;' +
    'void main() { vec3 n = normalize(vN); vec3 v = normalize(uEye - vW); if (dot(n, v) < 0.0) n = -n;' +
    ' float d = 0.62 * max(dot(n, uL1), 0.0) + 0.25 * max(dot(n, uL2), 0.0);' +
    ' float sp = pow(max(dot(n, normalize(uL1 + v)), 0.0), 40.0) * 0.25;' +
    ' gl_FragColor = vec4(uColor * (0.30 + d) + vec3(sp), uAlpha); }',
    ['aPos', 'aNor'], ['uVP', 'uModel', 'uNormal', 'uColor', 'uAlpha', 'uEye', 'uL1', 'uL2']);
  var lineProg = program(
    'attribute vec3 aPos; uniform mat4 uVP; void main() { gl_Position = uVP * vec4(aPos, 1.0); }',
    'precision mediump float; uniform vec4 uColor; void main() { gl_FragColor = uColor; }',
    ['aPos'], ['uVP', 'uColor']);

  function meshBuffer(pos, nor, idx) {
    var b = { p: gl.createBuffer(), n: gl.createBuffer(), i: gl.createBuffer(), count: idx.length };
    gl.bindBuffer(gl.ARRAY_BUFFER, b.p); gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(pos), gl.STATIC_DRAW);
    gl.bindBuffer(gl.ARRAY_BUFFER, b.n); gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(nor), gl.STATIC_DRAW);
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, b.i); gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, new Uint16Array(idx), gl.STATIC_DRAW);
    return b;
  }
  // Unit cylinder: radius 1, z from 0 to 1, with caps.
  function cylinderMesh(seg) {
    var p = [], n = [], i = [];
    for (var s = 0; s <= seg; s++) {
      var a = 2 * Math.PI * s / seg, c = Math.cos(a), si = Math.sin(a);
      p.push(c, si, 0, c, si, 1); n.push(c, si, 0, c, si, 0);
    }
    for (s = 0; s < seg; s++) { var b = 2 * s; i.push(b, b + 2, b + 1, b + 1, b + 2, b + 3); }
    [0, 1].forEach(function (z) {
      var c0 = p.length / 3; p.push(0, 0, z); n.push(0, 0, z ? 1 : -1);
      for (var s2 = 0; s2 <= seg; s2++) {
        var a2 = 2 * Math.PI * s2 / seg; p.push(Math.cos(a2), Math.sin(a2), z); n.push(0, 0, z ? 1 : -1);
      }
      for (s2 = 0; s2 < seg; s2++) i.push(c0, c0 + 1 + s2, c0 + 2 + s2);
    });
    return meshBuffer(p, n, i);
  }
  // Unit cone: base radius 1 at z = 0, apex at z = 1, with its base disk.
  function coneMesh(seg) {
    var p = [], n = [], i = [], k = 1 / Math.sqrt(2);
    for (var s = 0; s <= seg; s++) {
      var a = 2 * Math.PI * s / seg, c = Math.cos(a), si = Math.sin(a);
      p.push(c, si, 0, 0, 0, 1); n.push(c * k, si * k, k, c * k, si * k, k);
    }
    for (s = 0; s < seg; s++) i.push(2 * s, 2 * s + 2, 2 * s + 1);
    var c0 = p.length / 3; p.push(0, 0, 0); n.push(0, 0, -1);
    for (s = 0; s <= seg; s++) { var a3 = 2 * Math.PI * s / seg; p.push(Math.cos(a3), Math.sin(a3), 0); n.push(0, 0, -1); }
    for (s = 0; s < seg; s++) i.push(c0, c0 + 2 + s, c0 + 1 + s);
    return meshBuffer(p, n, i);
  }
  // Unit sphere.
  function sphereMesh(lat, lon) {
    var p = [], n = [], i = [];
    for (var a = 0; a <= lat; a++) {
      var th = Math.PI * a / lat;
      for (var b = 0; b <= lon; b++) {
        var ph = 2 * Math.PI * b / lon;
        var x = Math.sin(th) * Math.cos(ph), y = Math.sin(th) * Math.sin(ph), z = Math.cos(th);
        p.push(x, y, z); n.push(x, y, z);
      }
    }
    for (a = 0; a < lat; a++) {
      for (b = 0; b < lon; b++) {
        var q = a * (lon + 1) + b;
        i.push(q, q + lon + 1, q + 1, q + 1, q + lon + 1, q + lon + 2);
      }
    }
    return meshBuffer(p, n, i);
  }
  // Unit cube [−½, ½]³ with flat faces.
  function cubeMesh() {
    var p = [], n = [], i = [];
    [[0, 1], [0, -1], [1, 1], [1, -1], [2, 1], [2, -1]].forEach(function (f) {
      var ax = f[0], sg = f[1], u = (ax + 1) % 3, v = (ax + 2) % 3, c0 = p.length / 3;
      [[-1, -1], [1, -1], [1, 1], [-1, 1]].forEach(function (uv) {
        var q = [0, 0, 0], nn = [0, 0, 0];
        q[ax] = 0.5 * sg; q[u] = 0.5 * uv[0] * sg; q[v] = 0.5 * uv[1];
        nn[ax] = sg;
        p.push(q[0], q[1], q[2]); n.push(nn[0], nn[1], nn[2]);
      });
      i.push(c0, c0 + 1, c0 + 2, c0, c0 + 2, c0 + 3);
    });
    return meshBuffer(p, n, i);
  }
  var CYL = cylinderMesh(28), CONE = coneMesh(24), SPH = sphereMesh(12, 20), CUBE = cubeMesh();

  function lineBuffer(pts) {
    var b = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, b);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(pts), gl.STATIC_DRAW);
    return { b: b, count: pts.length / 3 };
  }

  // Table grid at z = 0: 10 cm lines, every metre darker, covering the scene's footprint.
  var g0x = Math.floor((lo[0] - 0.3) * 10) / 10, g1x = Math.ceil((hi[0] + 0.3) * 10) / 10;
  var g0y = Math.floor((lo[1] - 0.3) * 10) / 10, g1y = Math.ceil((hi[1] + 0.3) * 10) / 10;
  var gridMinor = [], gridMajor = [];
  for (var gx = Math.round(g0x * 10); gx <= Math.round(g1x * 10); gx++) {
    (gx % 10 === 0 ? gridMajor : gridMinor).push(gx / 10, g0y, 0, gx / 10, g1y, 0);
  }
  for (var gy = Math.round(g0y * 10); gy <= Math.round(g1y * 10); gy++) {
    (gy % 10 === 0 ? gridMajor : gridMinor).push(g0x, gy / 10, 0, g1x, gy / 10, 0);
  }
  var GRID_MINOR = lineBuffer(gridMinor), GRID_MAJOR = lineBuffer(gridMajor);
  var AXES = [lineBuffer([0, 0, 0, 0.2, 0, 0]), lineBuffer([0, 0, 0, 0, 0.2, 0]), lineBuffer([0, 0, 0, 0, 0, 0.2])];
  var desiredPts = [];
  S.desired.forEach(function (p) { if (finite3(p)) desiredPts.push(p[0], p[1], p[2]); });
  var DESIRED = lineBuffer(desiredPts);
  // Traced object path: frame k's point (the last valid one for invalid frames).
  var tracedPts = [];
  for (var k3 = 0; k3 < N; k3++) {
    var j3 = lastValid[k3] >= 0 ? lastValid[k3] : firstValid;
    var o3 = j3 >= 0 ? S.object[j3] : [0, 0, 0];
    tracedPts.push(o3[0], o3[1], o3[2]);
  }
  var TRACED = lineBuffer(tracedPts.length ? tracedPts : [0, 0, 0]);

  // ---------------------------------------------------------------------------------------
  // Camera: orbit about a target; yaw about world z, pitch above the table.
  var DEG = Math.PI / 180;
  var cam = {};
  function resetView() {
    cam.target = centre.slice();
    cam.yaw = -62 * DEG; cam.pitch = 24 * DEG;
    cam.dist = radius / Math.sin(20 * DEG) * 1.05;
  }
  function setView(name) {
    cam.target = centre.slice();
    cam.dist = radius / Math.sin(20 * DEG) * 1.0;
    if (name === 'front') { cam.yaw = -90 * DEG; cam.pitch = 0; }
    else if (name === 'side') { cam.yaw = 0; cam.pitch = 0; }
    else if (name === 'top') { cam.yaw = -90 * DEG; cam.pitch = 89.5 * DEG; }
    else resetView();
    dirty = true;
  }
  function eye() {
    var cp = Math.cos(cam.pitch);
    return add(cam.target, scl([cp * Math.cos(cam.yaw), cp * Math.sin(cam.yaw), Math.sin(cam.pitch)], cam.dist));
  }
  resetView();

  // ---------------------------------------------------------------------------------------
  // Drawing.
  var VP, EYE;
  function drawMesh(mesh, xf, colour, alpha) {
    var u = meshProg.u;
    gl.uniformMatrix4fv(u.uModel, false, xf.m);
    gl.uniformMatrix3fv(u.uNormal, false, xf.n);
    gl.uniform3fv(u.uColor, rgb(colour));
    gl.uniform1f(u.uAlpha, alpha === undefined ? 1 : alpha);
    gl.bindBuffer(gl.ARRAY_BUFFER, mesh.p); gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 0, 0);
    gl.bindBuffer(gl.ARRAY_BUFFER, mesh.n); gl.vertexAttribPointer(1, 3, gl.FLOAT, false, 0, 0);
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, mesh.i);
    gl.drawElements(gl.TRIANGLES, mesh.count, gl.UNSIGNED_SHORT, 0);
  }
  function cylinder(a, b, r, colour) {
    var d = sub(b, a), L = norm(d);
    if (!(L > 1e-6)) return;
    var e = perp(scl(d, 1 / L));
    drawMesh(CYL, basis(a, scl(e[0], r), scl(e[1], r), d), colour);
  }
  function sphere(c, r, colour) { drawMesh(SPH, basis(c, [r, 0, 0], [0, r, 0], [0, 0, r]), colour); }
  function arrow(o, v, r, colour) { // shaft + head, length |v|
    var L = norm(v);
    if (!(L > 1e-4) || !isFinite(L)) return;
    var d = scl(v, 1 / L), head = Math.min(0.35 * L, 6 * r), tip = add(o, v), hb = sub(tip, scl(d, head));
    cylinder(o, hb, r, colour);
    var e = perp(d);
    drawMesh(CONE, basis(hb, scl(e[0], 2.4 * r), scl(e[1], 2.4 * r), scl(d, head)), colour);
  }
  function lines(buf, colour, alpha, mode, count) {
    gl.uniform4f(lineProg.u.uColor, colour[0] / 255, colour[1] / 255, colour[2] / 255, alpha);
    gl.bindBuffer(gl.ARRAY_BUFFER, buf.b); gl.vertexAttribPointer(0, 3, gl.FLOAT, false, 0, 0);
    gl.drawArrays(mode, 0, count === undefined ? buf.count : count);
  }

  var cur = t0, playing = false, speed = 1, dirty = true, frame = null;

  function render() {
    var dpr = window.devicePixelRatio || 1;
    var w = Math.max(1, Math.round(canvas.clientWidth * dpr)), h = Math.max(1, Math.round(canvas.clientHeight * dpr));
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    gl.viewport(0, 0, w, h);
    gl.clearColor(0.933, 0.945, 0.961, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    gl.disable(gl.CULL_FACE);
    EYE = eye();
    var near = Math.max(0.01, cam.dist - 4 * radius - 2), far = cam.dist + 4 * radius + 2;
    VP = mul4(perspective(40 * DEG, w / h, near * 0.5, far), lookAt(EYE, cam.target, [0, 0, 1]));

    // Lines: grid, world axes, desired and traced paths.
    gl.useProgram(lineProg.p);
    gl.uniformMatrix4fv(lineProg.u.uVP, false, VP);
    gl.enableVertexAttribArray(0); gl.disableVertexAttribArray(1);
    lines(GRID_MINOR, C.grid, 1, gl.LINES);
    lines(GRID_MAJOR, C.grid10, 1, gl.LINES);
    lines(AXES[0], C.x, 1, gl.LINES); lines(AXES[1], C.y, 1, gl.LINES); lines(AXES[2], C.z, 1, gl.LINES);
    frame = frameAt(cur);

    gl.useProgram(meshProg.p);
    gl.enableVertexAttribArray(0); gl.enableVertexAttribArray(1);
    var u = meshProg.u;
    gl.uniformMatrix4fv(u.uVP, false, VP);
    gl.uniform3fv(u.uEye, EYE);
    // Lights follow the camera: key from the upper left of the view, fill from the right.
    var fwd = unit(sub(cam.target, EYE)), right = unit(cross(fwd, [0, 0, 1]));
    if (!(norm(right) > 0.5) || !isFinite(right[0])) right = [1, 0, 0];
    var camUp = cross(right, fwd);
    gl.uniform3fv(u.uL1, unit(add(add(scl(fwd, -1), scl(camUp, 0.8)), scl(right, -0.5))));
    gl.uniform3fv(u.uL2, unit(add(scl(fwd, -0.4), scl(right, 1))));

    if (frame) {
      // Arms: base pedestal, links as capsules (cylinders + joint spheres), tool frames.
      var tools = [];
      S.arms.forEach(function (a, i) {
        var col = ARM_COLOURS[i % ARM_COLOURS.length];
        var ja = a.joints[frame.k], jb = a.joints[frame.k2];
        var pts = [a.base].concat(ja.map(function (p, j) { return frame.k2 === frame.k ? p : lerp(p, jb[j], frame.s); }));
        var tool = poseAt(a.tool, frame);
        pts.push(tool.p);
        drawMesh(CYL, basis([a.base[0], a.base[1], 0], [0.09, 0, 0], [0, 0.09, 0], [0, 0, Math.max(0.02, a.base[2] + 0.02)]), C.base);
        for (var s = 0; s + 1 < pts.length; s++) {
          var r = s < 3 ? 0.034 : 0.027;
          cylinder(pts[s], pts[s + 1], r, col);
          if (s > 0) sphere(pts[s], r * 1.18, C.joint);
        }
        tools.push(tool);
      });
      // The object box, slightly transparent so that the tool frames inside stay visible.
      var ob = poseAt(S.object, frame), bs = S.box;
      gl.enable(gl.BLEND); gl.blendFunc(gl.SRC_ALPHA, gl.ONE_MINUS_SRC_ALPHA); gl.depthMask(false);
      drawMesh(CUBE, basis(ob.p, scl(qrot(ob.q, [1, 0, 0]), bs[0]), scl(qrot(ob.q, [0, 1, 0]), bs[1]), scl(qrot(ob.q, [0, 0, 1]), bs[2])), C.box, 0.78);
      gl.depthMask(true); gl.disable(gl.BLEND);
      // Tool frames and grasp wrenches after the box (which writes no depth), so that they
      // stay readable inside it; the arms still hide them.
      tools.forEach(function (tool, i) {
        var L = 0.09, ar = 0.0045;
        cylinder(tool.p, add(tool.p, qrot(tool.q, [L, 0, 0])), ar, C.x);
        cylinder(tool.p, add(tool.p, qrot(tool.q, [0, L, 0])), ar, C.y);
        cylinder(tool.p, add(tool.p, qrot(tool.q, [0, 0, L])), ar, C.z);
        sphere(tool.p, 0.009, [30, 30, 30]);
        if (!hasWrench) return;
        var wf = S.wrenches[frame.k], ws = wf && wf[i];
        if (ws && ws[0] !== null && ws[1] !== null && ws[2] !== null && fMax > 0) {
          arrow(tool.p, scl([ws[0], ws[1], ws[2]], 0.1 / fPer01), 0.007, C.force);
        }
        if (ws && ws[3] !== null && ws[4] !== null && ws[5] !== null && tMax > 0) {
          arrow(tool.p, scl([ws[3], ws[4], ws[5]], 0.1 / tPer01), 0.005, C.torque);
        }
      });
      // Contact pads: a disc on the face and its friction cone (half angle atan μ) opening out
      // of the box, green while it sticks, orange while it slips, grey once separated.
      (S.pads || []).forEach(function (pd) {
        var tool = tools[pd.arm];
        if (!tool) return;
        var st = pd.state[frame.k], col = st === 1 ? C.slip : (st === 2 ? C.separated : C.stick);
        var at = add(tool.p, qrot(tool.q, pd.p)), out = scl(unit(qrot(tool.q, pd.n)), -1);
        cylinder(at, add(at, scl(out, 0.004)), pd.r, col);
        var L = 0.04, e = perp(out), rb = L * Math.min(pd.mu, 3);
        gl.enable(gl.BLEND); gl.blendFunc(gl.SRC_ALPHA, gl.ONE_MINUS_SRC_ALPHA); gl.depthMask(false);
        drawMesh(CONE, basis(add(at, scl(out, L)), scl(e[0], rb), scl(e[1], rb), scl(out, -L)), col, 0.45);
        gl.depthMask(true); gl.disable(gl.BLEND);
      });
    }
    // The paths after the box too: they run through its centre.
    gl.useProgram(lineProg.p);
    gl.enableVertexAttribArray(0); gl.disableVertexAttribArray(1);
    // The desired path writes no depth, so the traced one shows on top where they coincide.
    gl.depthMask(false);
    if (DESIRED.count > 1) lines(DESIRED, C.desired, 1, gl.LINE_STRIP);
    gl.depthMask(true);
    if (frame && N > 0) {
      var upto = Math.min(N, frame.k + 1);
      if (upto > 1) lines(TRACED, C.traced, 1, gl.LINE_STRIP, upto);
    }
    updateHud();
    dirty = false;
  }

  // ---------------------------------------------------------------------------------------
  // HUD, legend and controls.
  function esc(s) { return String(s).replace(/[&<>"]/g, function (c) { return { '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' }[c]; }); }
  function vnorm(w, o) { // |w[o..o+3]|, NaN if a component is missing (null)
    if (w[o] === null || w[o + 1] === null || w[o + 2] === null) return NaN;
    return norm([w[o], w[o + 1], w[o + 2]]);
  }
  function fmt(v) {
    if (v === null || v === undefined || !isFinite(v)) return 'n/a';
    var a = Math.abs(v);
    if (a !== 0 && (a < 1e-3 || a >= 1e5)) return v.toExponential(3);
    return v.toPrecision(4);
  }
  function updateHud() {
    var f = frame, k = f ? f.k : 0, rows = [];
    rows.push('<h1>' + esc(S.title) + '</h1>');
    rows.push('<div class="num">t = ' + cur.toFixed(2) + ' s of ' + tEnd.toFixed(2) + ' s · frame ' + (N ? (k + 1) : 0) + ' / ' + N + '</div>');
    S.scalars.forEach(function (s) {
      var v = f && f.k2 !== f.k ? (s.values[f.k] === null || s.values[f.k2] === null ? null : s.values[f.k] + (s.values[f.k2] - s.values[f.k]) * f.s) : s.values[k];
      rows.push('<div class="num">' + esc(s.name) + ' = ' + fmt(v) + (s.unit ? ' ' + esc(s.unit) : '') + '</div>');
    });
    if (hasWrench && fMax > 0) rows.push('<div class="num">force arrows: 0.1 m = ' + Number(fPer01.toPrecision(3)) + ' N' + (tMax > 0 ? ' · torque arrows: 0.1 m = ' + Number(tPer01.toPrecision(3)) + ' N m' : '') + '</div>');
    if (f && hasWrench) S.arms.forEach(function (a, i) {
      var wf = S.wrenches[f.k], w = wf && wf[i];
      if (!w) return;
      rows.push('<div class="num">' + esc(a.name) + ': |f| = ' + fmt(vnorm(w, 0)) + ' N, |τ| = ' + fmt(vnorm(w, 3)) + ' N m</div>');
    });
    if (!hasWrench) rows.push('<div class="num">no grasp wrenches in this run</div>');
    if (firstValid < 0) rows.push('<div class="warn">no frame with finite values: nothing to draw</div>');
    else if (f && f.skipped) rows.push('<div class="warn">the frame at this time has non-finite values: frame ' + (f.k + 1) + ' is shown</div>');
    (S.notes || []).forEach(function (n) { rows.push('<div class="note">' + esc(n) + '</div>'); });
    hud.innerHTML = rows.join('');
    document.getElementById('tlabel').textContent = cur.toFixed(2) + ' / ' + tEnd.toFixed(2) + ' s';
    var sl = document.getElementById('slider');
    if (!sliding) sl.value = String(tEnd > t0 ? Math.round(10000 * (cur - t0) / (tEnd - t0)) : 0);
    document.getElementById('play').textContent = playing ? 'pause' : 'play';
  }
  (function legend() {
    var items = [];
    S.arms.forEach(function (a, i) { items.push([ARM_COLOURS[i % ARM_COLOURS.length], a.name]); });
    items.push([C.box, 'object box ' + S.box.map(function (v) { return v; }).join(' × ') + ' m']);
    if (S.pads && S.pads.length) {
      items.push([C.stick, 'pad sticking (friction cone)']);
      items.push([C.slip, 'pad slipping']);
      items.push([C.separated, 'pad separated']);
    }
    items.push([C.desired, 'desired path']);
    items.push([C.traced, 'object path (traced)']);
    if (hasWrench) { items.push([C.force, 'grasp force on the tool']); if (tMax > 0) items.push([C.torque, 'grasp torque on the tool']); }
    items.push([C.x, 'tool / world x']); items.push([C.y, 'tool / world y']); items.push([C.z, 'tool / world z']);
    items.push([C.grid10, 'table z = 0, grid 0.1 m']);
    document.getElementById('legend').innerHTML = items.map(function (it) {
      return '<div><i style="background:' + css(it[0]) + '"></i>' + esc(it[1]) + '</div>';
    }).join('');
  })();

  // CSS-pixel bounding box {x0, y0, x1, y1} of the arms' points at the current time (tests).
  function armScreenBox() {
    var f = frameAt(cur), box = { x0: Infinity, y0: Infinity, x1: -Infinity, y1: -Infinity };
    if (!f || !VP) return null;
    S.arms.forEach(function (a) {
      var pts = [a.base].concat(a.joints[f.k], [a.tool[f.k]]);
      pts.forEach(function (p) {
        var x = VP[0] * p[0] + VP[4] * p[1] + VP[8] * p[2] + VP[12];
        var y = VP[1] * p[0] + VP[5] * p[1] + VP[9] * p[2] + VP[13];
        var w = VP[3] * p[0] + VP[7] * p[1] + VP[11] * p[2] + VP[15];
        if (!(w > 0)) return;
        var sx = (x / w * 0.5 + 0.5) * canvas.clientWidth, sy = (0.5 - y / w * 0.5) * canvas.clientHeight;
        box.x0 = Math.min(box.x0, sx); box.y0 = Math.min(box.y0, sy);
        box.x1 = Math.max(box.x1, sx); box.y1 = Math.max(box.y1, sy);
      });
    });
    return isFinite(box.x0) ? box : null;
  }

  function seek(t) {
    var v = Number(t);
    if (!isFinite(v)) v = t0;
    cur = Math.min(tEnd, Math.max(t0, v));
    render();
    return cur;
  }
  function play() { if (cur >= tEnd) cur = t0; playing = true; last = null; dirty = true; }
  function pause() { playing = false; dirty = true; }

  var sliding = false, last = null;
  var slider = document.getElementById('slider');
  slider.addEventListener('input', function () { sliding = true; seek(t0 + (tEnd - t0) * Number(slider.value) / 10000); sliding = false; });
  document.getElementById('play').addEventListener('click', function () { if (playing) pause(); else play(); });
  document.getElementById('speed').addEventListener('change', function (e) { speed = Number(e.target.value) || 1; });
  document.getElementById('reset').addEventListener('click', function () { resetView(); dirty = true; });
  Array.prototype.forEach.call(document.querySelectorAll('[data-view]'), function (b) {
    b.addEventListener('click', function () { setView(b.getAttribute('data-view')); });
  });
  window.addEventListener('keydown', function (e) {
    if (e.target && (e.target.tagName === 'SELECT' || e.target.tagName === 'INPUT') && e.key !== ' ') return;
    if (e.key === ' ') { e.preventDefault(); if (playing) pause(); else play(); }
    else if (e.key === 'r') { resetView(); dirty = true; }
  });

  // Orbit (left drag), pan (right or shift drag), zoom (wheel).
  var drag = null;
  canvas.addEventListener('contextmenu', function (e) { e.preventDefault(); });
  canvas.addEventListener('mousedown', function (e) {
    drag = { x: e.clientX, y: e.clientY, pan: e.button === 2 || e.shiftKey };
    canvas.classList.add('dragging');
    e.preventDefault();
  });
  window.addEventListener('mouseup', function () { drag = null; canvas.classList.remove('dragging'); });
  window.addEventListener('mousemove', function (e) {
    if (!drag) return;
    var dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    drag.x = e.clientX; drag.y = e.clientY;
    if (drag.pan) {
      var fwd = unit(sub(cam.target, eye())), right = unit(cross(fwd, [0, 0, 1]));
      if (!isFinite(right[0]) || norm(right) < 0.5) right = [1, 0, 0];
      var upv = cross(right, fwd), k = cam.dist * 0.0016;
      cam.target = add(cam.target, add(scl(right, -dx * k), scl(upv, dy * k)));
    } else {
      cam.yaw -= dx * 0.008;
      cam.pitch = Math.max(-89.5 * DEG, Math.min(89.5 * DEG, cam.pitch + dy * 0.008));
    }
    dirty = true;
  });
  canvas.addEventListener('wheel', function (e) {
    e.preventDefault();
    cam.dist = Math.max(0.05, Math.min(100, cam.dist * Math.exp(e.deltaY * 0.0012)));
    dirty = true;
  }, { passive: false });
  window.addEventListener('resize', function () { dirty = true; });

  function tick(now) {
    if (playing) {
      if (last !== null) {
        cur += (now - last) / 1000 * speed;
        if (cur >= tEnd) { cur = tEnd; playing = false; }
      }
      last = now;
      dirty = true;
    } else {
      last = null;
    }
    if (dirty) render();
    window.requestAnimationFrame(tick);
  }
  render();
  api.ready = true;
  window.requestAnimationFrame(tick);
})();
