// meshlod view: draws the meshes embedded in this page with WebGL 1.
// Written for meshlod; no library, no network. The camera, light and colours are
// those of `meshlod render`: orthographic, framing the first level's bounding box
// (90% of the tighter side), a headlight with ambient light, back faces tinted,
// the heat map in viridis.
(function () {
  'use strict';

  var header = JSON.parse(document.getElementById('meshlod-header').textContent);
  var canvas = document.getElementById('view');
  var message = document.getElementById('message');

  function fail(text) {
    message.textContent = text;
    message.style.display = 'block';
  }

  var gl = canvas.getContext('webgl', { preserveDrawingBuffer: true, antialias: true }) ||
    canvas.getContext('experimental-webgl', { preserveDrawingBuffer: true });
  if (!gl) {
    fail('This browser cannot draw WebGL, which this page needs.');
    return;
  }
  var derivatives = gl.getExtension('OES_standard_derivatives');
  var uint32 = gl.getExtension('OES_element_index_uint');

  // ---- the embedded meshes -------------------------------------------------
  function decode(text) {
    var bin = atob(text.replace(/\s+/g, ''));
    var bytes = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) {
      bytes[i] = bin.charCodeAt(i);
    }
    return bytes.buffer;
  }
  var buffer = decode(document.getElementById('meshlod-data').textContent);
  if (buffer.byteLength !== header.bytes) {
    fail('The embedded mesh data is damaged (' + buffer.byteLength + ' bytes, expected ' +
      header.bytes + ').');
    return;
  }

  function arrayBuffer(target, data) {
    var b = gl.createBuffer();
    gl.bindBuffer(target, b);
    gl.bufferData(target, data, gl.STATIC_DRAW);
    return b;
  }

  var levels = header.levels.map(function (h) {
    var L = {
      header: h,
      positions: new Float32Array(buffer, h.positions, 3 * h.vertices),
      indices: h.index_bytes === 2 ?
        new Uint16Array(buffer, h.indices, 3 * h.triangles) :
        new Uint32Array(buffer, h.indices, 3 * h.triangles),
      colors: h.colors === undefined ? null : new Uint8Array(buffer, h.colors, 4 * h.vertices),
      heat: h.heat === undefined ? null : new Float32Array(buffer, h.heat, h.vertices),
      gpu: null,
      edges: null,
      normals: null
    };
    return L;
  });

  // Uploads a level's arrays on first use.
  function gpu(L) {
    if (!L.gpu) {
      L.gpu = {
        positions: arrayBuffer(gl.ARRAY_BUFFER, L.positions),
        indices: arrayBuffer(gl.ELEMENT_ARRAY_BUFFER, L.indices),
        colors: L.colors ? arrayBuffer(gl.ARRAY_BUFFER, L.colors) : null,
        heat: L.heat ? arrayBuffer(gl.ARRAY_BUFFER, L.heat) : null
      };
    }
    return L.gpu;
  }

  // Each edge once, as line pairs.
  function edges(L) {
    if (!L.edges) {
      var idx = L.indices, n = L.header.vertices, seen = new Map();
      var out = [];
      for (var t = 0; t < idx.length; t += 3) {
        for (var k = 0; k < 3; k++) {
          var a = idx[t + k], b = idx[t + (k + 1) % 3];
          var lo = Math.min(a, b), hi = Math.max(a, b);
          var key = lo * n + hi;
          if (!seen.has(key)) {
            seen.set(key, true);
            out.push(lo, hi);
          }
        }
      }
      var arr = L.header.index_bytes === 2 ? new Uint16Array(out) : new Uint32Array(out);
      L.edges = { buffer: arrayBuffer(gl.ELEMENT_ARRAY_BUFFER, arr), count: arr.length };
    }
    return L.edges;
  }

  // Area-weighted vertex normals, for smooth shading.
  function normals(L) {
    if (!L.normals) {
      var p = L.positions, idx = L.indices, n = new Float32Array(p.length);
      for (var t = 0; t < idx.length; t += 3) {
        var a = 3 * idx[t], b = 3 * idx[t + 1], c = 3 * idx[t + 2];
        var e1x = p[b] - p[a], e1y = p[b + 1] - p[a + 1], e1z = p[b + 2] - p[a + 2];
        var e2x = p[c] - p[a], e2y = p[c + 1] - p[a + 1], e2z = p[c + 2] - p[a + 2];
        var fx = e1y * e2z - e1z * e2y, fy = e1z * e2x - e1x * e2z, fz = e1x * e2y - e1y * e2x;
        for (var k = 0; k < 3; k++) {
          var v = 3 * idx[t + k];
          n[v] += fx;
          n[v + 1] += fy;
          n[v + 2] += fz;
        }
      }
      L.normals = arrayBuffer(gl.ARRAY_BUFFER, n);
    }
    return L.normals;
  }

  // ---- shaders -------------------------------------------------------------
  var VERTEX = [
    'attribute vec3 aPos;',
    'attribute vec4 aColor;',
    'attribute float aHeat;',
    'attribute vec3 aNormal;',
    'uniform vec3 uCenter, uRight, uUp, uFwd;',
    'uniform vec2 uScale;',
    'uniform float uDepth;',
    'varying vec3 vEye;',
    'varying vec4 vColor;',
    'varying float vHeat;',
    'varying vec3 vNormal;',
    'void main() {',
    '  vec3 d = aPos - uCenter;',
    '  vEye = vec3(dot(d, uRight), dot(d, uUp), dot(d, uFwd));',
    '  vColor = aColor;',
    '  vHeat = aHeat;',
    '  vNormal = vec3(dot(aNormal, uRight), dot(aNormal, uUp), dot(aNormal, uFwd));',
    '  gl_Position = vec4(vEye.x * uScale.x, vEye.y * uScale.y, vEye.z * uDepth, 1.0);',
    '}'
  ].join('\n');

  var FRAGMENT = [
    derivatives ? '#extension GL_OES_standard_derivatives : enable' : '',
    'precision highp float;',
    'varying vec3 vEye;',
    'varying vec4 vColor;',
    'varying float vHeat;',
    'varying vec3 vNormal;',
    'uniform vec3 uFront, uBack;',
    'uniform float uAmbient, uHeatAmbient, uHeatMax;',
    'uniform int uMode;',
    'uniform bool uSmooth;',
    'uniform vec3 uViridis[11];',
    'vec3 viridis(float t) {',
    '  float x = clamp(t, 0.0, 1.0) * 10.0;',
    '  vec3 c = uViridis[10];',
    '  for (int k = 0; k < 10; k++) {',
    '    if (x >= float(k) && x < float(k + 1)) { c = mix(uViridis[k], uViridis[k + 1], x - float(k)); }',
    '  }',
    '  return c;',
    '}',
    'void main() {',
    '  vec3 n = vec3(0.0, 0.0, 1.0);',
    derivatives ?
      '  if (uSmooth) { n = normalize(vNormal); } else { n = normalize(cross(dFdx(vEye), dFdy(vEye))); }' :
      '  n = normalize(vNormal);',
    '  float lambert = min(abs(n.z), 1.0);',
    '  vec3 base = uFront;',
    '  float ambient = uAmbient;',
    '  if (uMode == 2) {',
    '    base = viridis(uHeatMax > 0.0 ? vHeat / uHeatMax : 0.0);',
    '    ambient = uHeatAmbient;',
    '  } else if (!gl_FrontFacing) {',
    '    base = uBack;',
    '  } else if (uMode == 1) {',
    '    base = vColor.rgb;',
    '  }',
    '  gl_FragColor = vec4(base * (ambient + (1.0 - ambient) * lambert), 1.0);',
    '}'
  ].join('\n');

  var LINE_FRAGMENT = [
    'precision mediump float;',
    'uniform vec3 uWire;',
    'void main() { gl_FragColor = vec4(uWire, 1.0); }'
  ].join('\n');

  function shader(type, source) {
    var s = gl.createShader(type);
    gl.shaderSource(s, source);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) {
      throw new Error(gl.getShaderInfoLog(s));
    }
    return s;
  }

  function program(vs, fs) {
    var p = gl.createProgram();
    gl.attachShader(p, shader(gl.VERTEX_SHADER, vs));
    gl.attachShader(p, shader(gl.FRAGMENT_SHADER, fs));
    gl.bindAttribLocation(p, 0, 'aPos');
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) {
      throw new Error(gl.getProgramInfoLog(p));
    }
    var u = {}, a = {};
    var nu = gl.getProgramParameter(p, gl.ACTIVE_UNIFORMS);
    for (var i = 0; i < nu; i++) {
      var name = gl.getActiveUniform(p, i).name.replace(/\[0\]$/, '');
      u[name] = gl.getUniformLocation(p, name);
    }
    var na = gl.getProgramParameter(p, gl.ACTIVE_ATTRIBUTES);
    for (var j = 0; j < na; j++) {
      var an = gl.getActiveAttrib(p, j).name;
      a[an] = gl.getAttribLocation(p, an);
    }
    return { program: p, uniforms: u, attributes: a };
  }

  var surface, lines;
  try {
    surface = program(VERTEX, FRAGMENT);
    lines = program(VERTEX, LINE_FRAGMENT);
  } catch (e) {
    fail('WebGL could not compile the shaders: ' + e.message);
    return;
  }

  // ---- state and interface -------------------------------------------------
  var state = { level: 0, yaw: 0, pitch: 0, zoom: 1, wire: false, smooth: false, heat: !!header.heat };
  var ui = {
    title: document.getElementById('title'),
    levels: document.getElementById('levels'),
    wire: document.getElementById('wire'),
    smooth: document.getElementById('smooth'),
    heat: document.getElementById('heat'),
    heatbox: document.getElementById('heatbox'),
    info: document.getElementById('info'),
    legend: document.getElementById('legend')
  };
  ui.title.textContent = header.title + ' ';
  var buttons = levels.map(function (L, i) {
    var b = document.createElement('button');
    b.textContent = L.header.label;
    b.title = L.header.info;
    b.addEventListener('click', function () { setLevel(i); });
    ui.levels.appendChild(b);
    return b;
  });
  if (levels.length < 2) {
    ui.levels.style.display = 'none';
  }
  if (!header.heat) {
    ui.heatbox.style.display = 'none';
  } else {
    var stops = header.viridis.map(function (c, i) {
      return 'rgb(' + c.map(function (v) { return Math.round(v * 255); }).join(',') + ') ' + (10 * i) + '%';
    });
    document.getElementById('ramp').style.background = 'linear-gradient(to right, ' + stops.join(', ') + ')';
    document.getElementById('legendtitle').textContent =
      'distance to ' + header.heat.reference + ' (mesh units, at the vertices)';
    var pct = header.heat.diagonal > 0 ?
      ' (' + (100 * header.heat.max / header.heat.diagonal).toPrecision(3) + '% of its diagonal)' : '';
    document.getElementById('legendmax').textContent = header.heat.max.toPrecision(3) + pct;
  }

  function refreshUi() {
    buttons.forEach(function (b, i) { b.className = i === state.level ? 'on' : ''; });
    ui.wire.checked = state.wire;
    ui.smooth.checked = state.smooth;
    ui.heat.checked = state.heat;
    ui.legend.style.display = state.heat && header.heat ? 'block' : 'none';
    ui.info.textContent = levels[state.level].header.info;
  }

  function setLevel(i) {
    if (i >= 0 && i < levels.length) {
      state.level = i;
      refreshUi();
      schedule();
    }
  }

  ui.wire.addEventListener('change', function () { state.wire = ui.wire.checked; schedule(); });
  ui.smooth.addEventListener('change', function () { state.smooth = ui.smooth.checked; schedule(); });
  ui.heat.addEventListener('change', function () { state.heat = ui.heat.checked; refreshUi(); schedule(); });

  // ---- camera --------------------------------------------------------------
  var lo = header.bbox[0], hi = header.bbox[1];
  var center = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])];
  var radius = 0.5 * Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
  var MAX_PITCH = 0.5 * Math.PI - 1e-3;

  function cross(a, b) {
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  }
  function normalize(a) {
    var l = Math.hypot(a[0], a[1], a[2]);
    return [a[0] / l, a[1] / l, a[2] / l];
  }

  // Right, up and forward of the view (as `meshlod render` builds them).
  function axes() {
    var cp = Math.cos(state.pitch);
    var f = [-Math.sin(state.yaw) * cp, -Math.sin(state.pitch), -Math.cos(state.yaw) * cp];
    var hint = f[1] < -0.999 ? [0, 0, -1] : (f[1] > 0.999 ? [0, 0, 1] : [0, 1, 0]);
    var r = normalize(cross(f, hint));
    return [r, cross(r, f), f];
  }

  // Pixels per mesh unit that frame the first level's box from the front.
  function baseScale(w, h) {
    var er = hi[0] - lo[0], eu = hi[1] - lo[1];
    var s = Math.min(er > 0 ? 0.9 * w / er : Infinity, eu > 0 ? 0.9 * h / eu : Infinity);
    return isFinite(s) ? s : 1;
  }

  // ---- drawing -------------------------------------------------------------
  var pending = false;
  function schedule() {
    if (!pending) {
      pending = true;
      requestAnimationFrame(function () { pending = false; draw(); });
    }
  }

  function setCamera(p, w, h) {
    var ax = axes(), s = baseScale(w, h) * state.zoom, u = p.uniforms;
    gl.uniform3fv(u.uCenter, center);
    gl.uniform3fv(u.uRight, ax[0]);
    gl.uniform3fv(u.uUp, ax[1]);
    gl.uniform3fv(u.uFwd, ax[2]);
    gl.uniform2f(u.uScale, 2 * s / w, 2 * s / h);
    gl.uniform1f(u.uDepth, 1 / (1.01 * radius || 1));
  }

  function attribute(p, name, buffer, size, type, normalized, constant) {
    var loc = p.attributes[name];
    if (loc === undefined || loc < 0) {
      return;
    }
    if (buffer) {
      gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
      gl.enableVertexAttribArray(loc);
      gl.vertexAttribPointer(loc, size, type, normalized, 0, 0);
    } else {
      gl.disableVertexAttribArray(loc);
      gl.vertexAttrib4fv(loc, constant);
    }
  }

  function draw() {
    var dpr = window.devicePixelRatio || 1;
    var w = Math.max(1, Math.round(canvas.clientWidth * dpr));
    var h = Math.max(1, Math.round(canvas.clientHeight * dpr));
    if (canvas.width !== w || canvas.height !== h) {
      canvas.width = w;
      canvas.height = h;
    }
    gl.viewport(0, 0, w, h);
    gl.clearColor(1, 1, 1, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    var L = levels[state.level];
    if (L.header.index_bytes === 4 && !uint32) {
      fail(L.header.label + ' has more than 65,535 vertices, which this browser\'s WebGL cannot index.');
      return;
    }
    message.style.display = 'none';
    var g = gpu(L);
    var smooth = state.smooth || !derivatives;
    var heat = state.heat && L.heat;
    var indexType = L.header.index_bytes === 2 ? gl.UNSIGNED_SHORT : gl.UNSIGNED_INT;
    gl.enable(gl.DEPTH_TEST);
    gl.depthFunc(gl.LEQUAL);

    var p = surface, u = p.uniforms;
    gl.useProgram(p.program);
    setCamera(p, w, h);
    gl.uniform3fv(u.uFront, header.front);
    gl.uniform3fv(u.uBack, header.back);
    gl.uniform1f(u.uAmbient, header.ambient);
    gl.uniform1f(u.uHeatAmbient, header.heat_ambient);
    gl.uniform1f(u.uHeatMax, header.heat ? header.heat.max : 0);
    gl.uniform1i(u.uMode, heat ? 2 : (L.colors ? 1 : 0));
    gl.uniform1i(u.uSmooth, smooth ? 1 : 0);
    gl.uniform3fv(u.uViridis, [].concat.apply([], header.viridis));
    attribute(p, 'aPos', g.positions, 3, gl.FLOAT, false);
    attribute(p, 'aColor', g.colors, 4, gl.UNSIGNED_BYTE, true, [1, 1, 1, 1]);
    attribute(p, 'aHeat', heat ? g.heat : null, 1, gl.FLOAT, false, [0, 0, 0, 0]);
    attribute(p, 'aNormal', smooth ? normals(L) : null, 3, gl.FLOAT, false, [0, 0, 1, 0]);
    gl.enable(gl.POLYGON_OFFSET_FILL);
    gl.polygonOffset(1, 1);
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, g.indices);
    gl.drawElements(gl.TRIANGLES, 3 * L.header.triangles, indexType, 0);
    gl.disable(gl.POLYGON_OFFSET_FILL);

    if (state.wire) {
      var e = edges(L);
      p = lines;
      gl.useProgram(p.program);
      setCamera(p, w, h);
      gl.uniform3fv(p.uniforms.uWire, header.wire.map(function (v) { return v / 255; }));
      attribute(p, 'aPos', g.positions, 3, gl.FLOAT, false);
      ['aColor', 'aHeat', 'aNormal'].forEach(function (n) { attribute(p, n, null, 0, 0, false, [0, 0, 0, 0]); });
      gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, e.buffer);
      gl.drawElements(gl.LINES, e.count, indexType, 0);
    }
  }

  // ---- input ---------------------------------------------------------------
  var pointers = new Map();
  var pinch = 0;
  function spread() {
    var ps = Array.from(pointers.values());
    return Math.hypot(ps[0].x - ps[1].x, ps[0].y - ps[1].y);
  }
  canvas.addEventListener('pointerdown', function (ev) {
    canvas.setPointerCapture(ev.pointerId);
    pointers.set(ev.pointerId, { x: ev.clientX, y: ev.clientY });
    if (pointers.size === 2) {
      pinch = spread();
    }
    canvas.style.cursor = 'grabbing';
  });
  canvas.addEventListener('pointermove', function (ev) {
    var last = pointers.get(ev.pointerId);
    if (!last) {
      return;
    }
    if (pointers.size === 1) {
      state.yaw -= 0.01 * (ev.clientX - last.x);
      state.pitch = Math.max(-MAX_PITCH, Math.min(MAX_PITCH, state.pitch + 0.01 * (ev.clientY - last.y)));
    }
    last.x = ev.clientX;
    last.y = ev.clientY;
    if (pointers.size === 2) {
      var d = spread();
      if (pinch > 0 && d > 0) {
        state.zoom *= d / pinch;
      }
      pinch = d;
    }
    schedule();
  });
  function release(ev) {
    pointers.delete(ev.pointerId);
    pinch = pointers.size === 2 ? spread() : 0;
    if (pointers.size === 0) {
      canvas.style.cursor = 'grab';
    }
  }
  canvas.addEventListener('pointerup', release);
  canvas.addEventListener('pointercancel', release);
  canvas.addEventListener('wheel', function (ev) {
    ev.preventDefault();
    state.zoom *= Math.exp(-0.0015 * ev.deltaY);
    schedule();
  }, { passive: false });
  window.addEventListener('keydown', function (ev) {
    var k = ev.key;
    if (k === 'w' || k === 'W') {
      state.wire = !state.wire;
    } else if (k === 's' || k === 'S') {
      state.smooth = !state.smooth;
    } else if ((k === 'h' || k === 'H') && header.heat) {
      state.heat = !state.heat;
    } else if (k === 'r' || k === 'R') {
      state.yaw = 0;
      state.pitch = 0;
      state.zoom = 1;
    } else if (k >= '1' && k <= '9') {
      state.level = Math.min(levels.length - 1, k.charCodeAt(0) - 49);
    } else if (k === '[') {
      state.level = Math.max(0, state.level - 1);
    } else if (k === ']') {
      state.level = Math.min(levels.length - 1, state.level + 1);
    } else {
      return;
    }
    refreshUi();
    schedule();
  });
  window.addEventListener('resize', draw);
  window.addEventListener('load', draw);

  refreshUi();
  draw();
})();
