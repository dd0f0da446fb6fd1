// Formica live viewer: polls the server's JSON state and draws it on a canvas.
// Plain JavaScript, no libraries, nothing fetched from anywhere but this server.
'use strict';

(function () {
  const $ = (id) => document.getElementById(id);
  const canvas = $('view');
  const ctx = canvas.getContext('2d');
  const MAX_ROWS = 200;

  const viewer = {
    scene: null,
    state: null,
    frames: 0,
    robotsDrawn: 0,
    highlight: -1,
    selected: -1,
    robot: null,
    series: null,
    frame: null,
    toPixel(x, y) {
      const f = viewer.frame;
      if (!f) return [0, 0];
      return [(x - f.minX) * f.scale, f.h - (y - f.minY) * f.scale];
    },
    toWorld(px, py) {
      const f = viewer.frame;
      if (!f) return [0, 0];
      return [px / f.scale + f.minX, (f.h - py) / f.scale + f.minY];
    },
  };
  window.formicaViewer = viewer;

  function showError(msg) {
    $('error').textContent = msg || '';
  }

  async function api(method, path) {
    const r = await fetch(path, { method, cache: 'no-store' });
    const body = await r.json().catch(() => ({ error: 'bad JSON from the server' }));
    if (!r.ok) throw new Error(body.error || ('HTTP ' + r.status));
    return body;
  }

  function query() {
    const q = [];
    if ($('show-rays').checked) q.push('rays=1');
    if ($('show-zones').checked) q.push('zones=1');
    return q.length ? '?' + q.join('&') : '';
  }

  // ---- frame ----
  function fit() {
    const s = viewer.scene;
    if (!s) return;
    const spanX = s.arena.size[0] + 0.4;
    const spanY = s.arena.size[1] + 0.4;
    const cssW = Math.max(300, Math.floor(canvas.parentElement.clientWidth || 900));
    const dpr = window.devicePixelRatio || 1;
    const scaleCss = cssW / spanX;
    const cssH = Math.ceil(spanY * scaleCss);
    canvas.width = Math.round(cssW * dpr);
    canvas.height = Math.round(cssH * dpr);
    canvas.style.height = cssH + 'px';
    viewer.frame = {
      scale: scaleCss * dpr,
      minX: s.arena.center[0] - spanX / 2,
      minY: s.arena.center[1] - spanY / 2,
      h: canvas.height,
      dpr,
    };
  }

  const P = (p) => viewer.toPixel(p[0], p[1]);

  function poly(pts) {
    ctx.beginPath();
    pts.forEach((p, i) => {
      const [x, y] = P(p);
      if (i === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
    });
    ctx.closePath();
  }

  function rgb(c, a) {
    return a === undefined ? `rgb(${c[0]},${c[1]},${c[2]})` : `rgba(${c[0]},${c[1]},${c[2]},${a})`;
  }

  function transform(p, pose) {
    const c = Math.cos(pose.theta), s = Math.sin(pose.theta);
    return [pose.x + c * p[0] - s * p[1], pose.y + s * p[0] + c * p[1]];
  }

  // ---- drawing ----
  function draw() {
    const s = viewer.scene, st = viewer.state, f = viewer.frame;
    if (!s || !st || !f) return;
    const px = f.scale; // pixels per metre
    const lw = f.dpr;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.fillStyle = '#fafaf7';
    ctx.fillRect(0, 0, canvas.width, canvas.height);

    // Goal radius and lights.
    // Lights move on a schedule (`path`): the state has where they are now.
    const lightAt = (l, i) => (st.lights && st.lights[i]) || l.at;
    const gi = s.lights.findIndex((l) => l.goal);
    const goal = gi >= 0 ? s.lights[gi] : undefined;
    if (goal && s.goal_radius) {
      const [gx, gy] = P(lightAt(goal, gi));
      ctx.beginPath();
      ctx.arc(gx, gy, s.goal_radius * px, 0, 2 * Math.PI);
      ctx.fillStyle = '#fff4be';
      ctx.fill();
      ctx.strokeStyle = '#dcbe3c';
      ctx.lineWidth = lw;
      ctx.stroke();
    }

    // Occluded zone (under everything solid).
    if (st.zones && st.zones.length) {
      ctx.beginPath();
      for (const z of st.zones) {
        z.forEach((p, i) => {
          const [x, y] = P(p);
          if (i === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
        });
        ctx.closePath();
      }
      ctx.fillStyle = 'rgba(60,60,90,0.22)';
      ctx.fill('nonzero');
    }

    for (const [i, l] of s.lights.entries()) {
      const [x, y] = P(lightAt(l, i));
      ctx.beginPath();
      ctx.arc(x, y, 0.05 * px, 0, 2 * Math.PI);
      ctx.fillStyle = l.goal ? '#fac800' : '#e0c060';
      ctx.fill();
      ctx.strokeStyle = '#8a6d00';
      ctx.lineWidth = lw;
      ctx.stroke();
    }

    // Walls.
    ctx.fillStyle = '#6e6e6e';
    for (const w of s.walls) {
      poly(w);
      ctx.fill();
    }

    // Objects.
    s.objects.forEach((o, i) => {
      const pose = st.objects[i];
      if (!pose) return;
      for (const outline of o.outlines) {
        poly(outline.map((p) => transform(p, pose)));
        ctx.fillStyle = rgb(o.rgb);
        ctx.fill();
        ctx.strokeStyle = '#143c14';
        ctx.lineWidth = lw;
        ctx.stroke();
      }
    });

    // Path.
    if ($('show-path').checked && st.path.length >= 2) {
      ctx.beginPath();
      st.path.forEach((p, i) => {
        const [x, y] = P(p);
        if (i === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
      });
      ctx.strokeStyle = '#c81e1e';
      ctx.lineWidth = 2 * lw;
      ctx.stroke();
    }

    // Sensor rays and light lines.
    if (goal) {
      for (const r of st.robots) {
        if (r.sees_goal === undefined) continue;
        const [x0, y0] = P([r.x, r.y]);
        const [x1, y1] = P(goal.at);
        ctx.beginPath();
        ctx.moveTo(x0, y0);
        ctx.lineTo(x1, y1);
        ctx.strokeStyle = r.sees_goal ? 'rgba(230,180,0,0.25)' : 'rgba(80,80,120,0.12)';
        ctx.lineWidth = lw;
        ctx.stroke();
      }
    }
    for (const r of st.robots) {
      if (!r.rays) continue;
      const g = s.groups[r.group];
      const reach = g.radius + g.proximity_range;
      g.proximity_angles.forEach((a, k) => {
        const hit = r.rays[k];
        const d = hit === null || hit === undefined ? reach : hit;
        const th = r.theta + a;
        const [x0, y0] = P([r.x + Math.cos(th) * g.radius, r.y + Math.sin(th) * g.radius]);
        const [x1, y1] = P([r.x + Math.cos(th) * d, r.y + Math.sin(th) * d]);
        ctx.beginPath();
        ctx.moveTo(x0, y0);
        ctx.lineTo(x1, y1);
        ctx.strokeStyle = hit === null || hit === undefined ? 'rgba(40,120,220,0.45)' : '#e0501e';
        ctx.lineWidth = lw;
        ctx.stroke();
      });
    }

    // Robots.
    let drawn = 0;
    st.robots.forEach((r, i) => {
      if (!r.released) return;
      const g = s.groups[r.group];
      const [x, y] = P([r.x, r.y]);
      const rad = Math.max(1.5 * lw, g.radius * px);
      ctx.beginPath();
      ctx.arc(x, y, rad, 0, 2 * Math.PI);
      ctx.fillStyle = rgb(r.rgb);
      ctx.fill();
      ctx.strokeStyle = r.attached ? '#0050c8' : '#1e1e1e';
      ctx.lineWidth = (r.attached ? 2 : 1) * lw;
      ctx.stroke();
      ctx.beginPath();
      ctx.moveTo(x, y);
      ctx.lineTo(x + Math.cos(r.theta) * rad, y - Math.sin(r.theta) * rad);
      ctx.strokeStyle = '#000';
      ctx.lineWidth = 1.5 * lw;
      ctx.stroke();
      if (i === viewer.highlight || i === viewer.selected) {
        ctx.beginPath();
        ctx.arc(x, y, rad + 4 * lw, 0, 2 * Math.PI);
        ctx.strokeStyle = '#e000a0';
        ctx.lineWidth = (i === viewer.selected ? 3 : 2) * lw;
        ctx.stroke();
      }
      drawn += 1;
    });
    viewer.robotsDrawn = drawn;
    viewer.frames += 1;
    canvas.dataset.robotsDrawn = String(drawn);
    canvas.dataset.tick = String(st.tick);
  }

  // ---- panel ----
  let rowsFor = -1;
  function buildRows() {
    const tbody = $('robots').querySelector('tbody');
    tbody.textContent = '';
    const n = Math.min(viewer.scene.robots, MAX_ROWS);
    for (let i = 0; i < n; i++) {
      const tr = document.createElement('tr');
      tr.dataset.robot = String(i);
      for (let k = 0; k < 4; k++) tr.appendChild(document.createElement('td'));
      tr.cells[0].textContent = String(i);
      tr.addEventListener('mouseenter', () => { viewer.highlight = i; draw(); });
      tr.addEventListener('mouseleave', () => { viewer.highlight = -1; draw(); });
      tr.addEventListener('click', () => select(i));
      tbody.appendChild(tr);
    }
    $('robots-more').textContent = viewer.scene.robots > MAX_ROWS
      ? `(first ${MAX_ROWS} of ${viewer.scene.robots} shown)` : '';
    rowsFor = viewer.scene.generation;
  }

  function panel() {
    const st = viewer.state;
    $('s-time').textContent = `${st.time_s.toFixed(1)} s of ${st.duration_s} s`;
    $('s-tick').textContent = String(st.tick);
    const oc = $('s-outcome');
    oc.textContent = st.outcome || (st.playing ? 'running' : 'paused');
    oc.className = st.outcome ? 'outcome-' + st.outcome : '';
    $('s-seed').textContent = String(st.seed);
    $('s-robots').textContent = `${st.released} of ${st.robots_total} released`;
    $('s-goal').textContent = st.goal_distance_m == null ? '-' : st.goal_distance_m.toFixed(3) + ' m';
    $('s-path').textContent = st.object_path_m == null ? '–' : st.object_path_m.toFixed(3) + ' m';
    $('s-states').textContent = Object.entries(st.states).map(([k, v]) => `${k} ${v}`).join(', ');
    $('play').textContent = st.playing ? 'Pause' : 'Play';
    $('play').disabled = !!st.outcome;
    $('step').disabled = !!st.outcome;
    if (document.activeElement !== $('seed')) $('seed').value = String(st.seed);
    if (document.activeElement !== $('speed')) {
      const opt = Array.from($('speed').options).find((o) => Number(o.value) === st.speed);
      if (opt) $('speed').value = opt.value;
    }
    if (rowsFor !== st.generation) buildRows();
    const rows = $('robots').querySelector('tbody').rows;
    for (let i = 0; i < rows.length && i < st.robots.length; i++) {
      const r = st.robots[i];
      const c = rows[i].cells;
      c[1].textContent = r.state;
      if (!c[2].firstChild || c[2].dataset.led !== r.led) {
        c[2].textContent = '';
        const dot = document.createElement('span');
        dot.className = 'led';
        dot.style.background = r.led === 'off' ? 'transparent' : `rgb(${r.rgb.join(',')})`;
        c[2].appendChild(dot);
        c[2].appendChild(document.createTextNode(r.led));
        c[2].dataset.led = r.led;
      }
      c[3].textContent = r.attached ? 'yes' : '';
      rows[i].className = i === viewer.selected ? 'sel' : (i === viewer.highlight ? 'hl' : '');
    }
    replayBanner();
    document.body.dataset.tick = String(st.tick);
    document.body.dataset.generation = String(st.generation);
  }

  // ---- replay ----
  function replayBanner() {
    const el = $('replay');
    const rp = viewer.scene && viewer.scene.replay;
    if (!rp) { el.hidden = true; return; }
    el.hidden = false;
    const st = viewer.state && viewer.state.replay;
    const stored = `${rp.stored_outcome} after ${rp.stored_time_s.toFixed(1)} s (${rp.stored_ticks} ticks)`;
    const params = rp.params.map(([k, v]) => `${k} = ${v}`).join(', ');
    el.textContent = `Replay of ${rp.label}, seed ${rp.seed}${params ? ' (' + params + ')' : ''}. Stored outcome: ${stored}. `;
    const verdict = document.createElement('span');
    let check = 'running';
    if (!st || !st.active) {
      check = 'inactive';
      verdict.textContent = 'Another seed is running: restart with seed ' + rp.seed + ' to replay the trial.';
    } else if (!st.ended) {
      verdict.textContent = 'Running; the replay is checked when it ends.';
    } else if (st.matches) {
      check = 'match';
      verdict.className = 'match';
      verdict.textContent = '\u2713 The replay ended exactly as stored.';
    } else {
      check = 'differs';
      verdict.className = 'differs';
      verdict.textContent = '\u2717 The replay differs from the store: ' + st.differences.join('; ');
    }
    el.appendChild(verdict);
    el.dataset.check = check;
  }

  // ---- small charts ----
  const PALETTE = ['#1f77b4', '#ff7f0e', '#2ca02c', '#d62728', '#9467bd', '#8c564b', '#e377c2', '#7f7f7f', '#bcbd22', '#17becf'];
  const stateColors = new Map();
  function stateColor(name) {
    if (!stateColors.has(name)) stateColors.set(name, PALETTE[stateColors.size % PALETTE.length]);
    return stateColors.get(name);
  }

  function sizeCanvas(c) {
    const dpr = window.devicePixelRatio || 1;
    const w = Math.round(c.clientWidth * dpr) || c.width;
    const h = Math.round(c.clientHeight * dpr) || c.height;
    if (c.width !== w || c.height !== h) { c.width = w; c.height = h; }
    const g = c.getContext('2d');
    g.setTransform(1, 0, 0, 1, 0, 0);
    g.clearRect(0, 0, w, h);
    return [g, w, h, dpr];
  }

  // Lines of `lines` ([{ys, color}]) against `xs` on canvas `c`, with the y range labelled.
  function linePlot(c, xs, lines, yMinFloor) {
    const [g, w, h, dpr] = sizeCanvas(c);
    const pad = 4 * dpr, left = 34 * dpr, bottom = 12 * dpr;
    let lo = Infinity, hi = -Infinity;
    for (const l of lines) for (const y of l.ys) if (y !== null && y !== undefined) { lo = Math.min(lo, y); hi = Math.max(hi, y); }
    if (!isFinite(lo)) { lo = 0; hi = 1; }
    if (yMinFloor !== undefined) lo = Math.min(lo, yMinFloor);
    if (hi - lo < 1e-9) hi = lo + 1;
    const x0 = xs.length ? xs[0] : 0, x1 = xs.length ? Math.max(xs[xs.length - 1], x0 + 1e-9) : 1;
    const X = (x) => left + (x - x0) / (x1 - x0) * (w - left - pad);
    const Y = (y) => pad + (1 - (y - lo) / (hi - lo)) * (h - pad - bottom);
    g.strokeStyle = '#bbb';
    g.lineWidth = dpr;
    g.strokeRect(left, pad, w - left - pad, h - pad - bottom);
    g.fillStyle = '#555';
    g.font = `${10 * dpr}px sans-serif`;
    g.fillText(hi.toPrecision(3), 2 * dpr, pad + 9 * dpr);
    g.fillText(lo.toPrecision(3), 2 * dpr, h - bottom);
    g.fillText(`${x0.toFixed(0)}-${x1.toFixed(0)} s`, left + 2 * dpr, h - 1 * dpr);
    for (const l of lines) {
      g.beginPath();
      let started = false;
      l.ys.forEach((y, k) => {
        if (y === null || y === undefined) { started = false; return; }
        if (!started) { g.moveTo(X(xs[k]), Y(y)); started = true; } else g.lineTo(X(xs[k]), Y(y));
      });
      g.strokeStyle = l.color;
      g.lineWidth = 1.5 * dpr;
      g.stroke();
    }
  }

  function legend(el, names) {
    el.textContent = '';
    for (const n of names) {
      const s = document.createElement('span');
      const sw = document.createElement('span');
      sw.className = 'swatch';
      sw.style.background = stateColor(n);
      s.appendChild(sw);
      s.appendChild(document.createTextNode(n));
      el.appendChild(s);
    }
  }

  function drawPlots() {
    const se = viewer.series;
    if (!se) return;
    linePlot($('plot-goal'), se.t_s, [{ ys: se.goal_distance_m, color: '#c81e1e' }], 0);
    linePlot($('plot-speed'), se.t_s, [{ ys: se.object_speed_m_s, color: '#1f5fb4' }], 0);
    linePlot($('plot-states'), se.t_s, se.states.map((n, k) => ({ ys: se.robots_in_state[k], color: stateColor(n) })), 0);
    legend($('plot-states-legend'), se.states);
    document.getElementById('plots').dataset.points = String(se.t_s.length);
  }

  let seriesAt = 0, seriesTick = -1;
  async function refreshSeries(force) {
    const st = viewer.state;
    if (!st) return;
    const now = Date.now();
    if (!force && st.tick === seriesTick) return;
    if (!force && st.playing && now - seriesAt < 1000) return;
    seriesAt = now;
    seriesTick = st.tick;
    viewer.series = await api('GET', '/api/series');
    drawPlots();
  }

  // ---- robot inspector ----
  function select(i) {
    viewer.selected = i;
    viewer.robot = null;
    $('inspect').hidden = i < 0;
    if (viewer.state) { panel(); draw(); }
    if (i >= 0) inspect().catch((e) => showError(e.message));
  }

  function polar(c, draw1) {
    const [g, w, h, dpr] = sizeCanvas(c);
    const cx = w / 2, cy = h / 2, R = Math.min(w, h) / 2 - 4 * dpr;
    g.strokeStyle = '#ccc';
    g.lineWidth = dpr;
    for (const f of [0.5, 1]) { g.beginPath(); g.arc(cx, cy, R * f, 0, 2 * Math.PI); g.stroke(); }
    // Straight ahead is up.
    g.beginPath(); g.moveTo(cx, cy); g.lineTo(cx, cy - R); g.strokeStyle = '#999'; g.stroke();
    const at = (bearing, f) => [cx - Math.sin(bearing) * R * f, cy - Math.cos(bearing) * R * f];
    draw1(g, at, dpr);
  }

  function drawInspector() {
    const r = viewer.robot;
    if (!r) return;
    $('i-title').textContent = 'Robot ' + r.robot;
    $('i-controller').textContent = r.controller;
    $('i-state').textContent = r.state;
    $('i-led').textContent = r.led;
    $('i-attached').textContent = r.attached ? 'yes' : 'no';
    $('i-wheels').textContent = `${r.wheels[0].toFixed(3)}, ${r.wheels[1].toFixed(3)}`;
    $('inspect').dataset.robot = String(r.robot);
    $('inspect').dataset.proximity = JSON.stringify(r.readings.proximity);
    $('inspect').dataset.light = JSON.stringify(r.readings.light);
    // Proximity: one bar per sensor, in [0, 1].
    {
      const [g, w, h, dpr] = sizeCanvas($('i-prox'));
      const p = r.readings.proximity;
      const n = Math.max(1, p.length);
      const bw = w / n;
      g.fillStyle = '#f3f3f3';
      g.fillRect(0, 0, w, h);
      p.forEach((v, k) => {
        const bh = Math.max(0, Math.min(1, v)) * (h - 12 * dpr);
        g.fillStyle = v > 0 ? '#e0501e' : '#ccc';
        g.fillRect(k * bw + 1, h - 12 * dpr - bh, bw - 2, Math.max(bh, dpr));
        // Bearings (degrees), as many as fit.
        const every = Math.ceil(22 * dpr / bw);
        if (k % every === 0) {
          g.fillStyle = '#555';
          g.font = `${9 * dpr}px sans-serif`;
          const deg = Math.round((r.proximity_angles[k] || 0) * 180 / Math.PI);
          g.fillText(String(deg), k * bw + 1, h - 2 * dpr);
        }
      });
    }
    // Light: polar, one spoke per sensor.
    polar($('i-light'), (g, at, dpr) => {
      const l = r.readings.light;
      if (!l.length) return;
      g.beginPath();
      l.forEach((v, k) => {
        const [x, y] = at(r.light_angles[k] || 0, Math.max(0, Math.min(1, v)));
        if (k === 0) g.moveTo(x, y); else g.lineTo(x, y);
      });
      g.closePath();
      g.fillStyle = 'rgba(250,200,0,0.5)';
      g.fill();
      g.strokeStyle = '#b08a00';
      g.lineWidth = 1.5 * dpr;
      g.stroke();
    });
    // Camera: blobs at their bearing, distance scaled to the farthest (at least 1 m).
    const blobs = r.readings.blobs;
    $('i-blobs').textContent = String(blobs.length);
    polar($('i-camera'), (g, at, dpr) => {
      const far = Math.max(1, ...blobs.map((b) => b.distance));
      for (const b of blobs) {
        const [x, y] = at(b.bearing, Math.min(1, b.distance / far));
        g.beginPath();
        g.arc(x, y, 3.5 * dpr, 0, 2 * Math.PI);
        g.fillStyle = rgb(b.rgb);
        g.fill();
        g.strokeStyle = '#222';
        g.lineWidth = dpr;
        g.stroke();
      }
    });
    // State history: coloured bands over the last minute.
    {
      const [g, w, h] = sizeCanvas($('i-history'));
      const t1 = r.time_s, t0 = t1 - r.history_s;
      const X = (t) => (Math.max(t0, t) - t0) / (t1 - t0) * w;
      const hist = r.history;
      const names = [];
      hist.forEach((e, k) => {
        const end = k + 1 < hist.length ? hist[k + 1].t_s : t1;
        g.fillStyle = stateColor(e.state);
        g.fillRect(X(e.t_s), 0, Math.max(1, X(end) - X(e.t_s)), h);
        if (!names.includes(e.state)) names.push(e.state);
      });
      legend($('i-history-legend'), names);
      $('i-history-s').textContent = String(r.history_s);
    }
  }

  let inspecting = false;
  async function inspect() {
    if (viewer.selected < 0 || inspecting) return;
    inspecting = true;
    try {
      const want = viewer.selected;
      const r = await api('GET', '/api/robot?i=' + want);
      if (viewer.selected === want) { viewer.robot = r; drawInspector(); }
    } finally {
      inspecting = false;
    }
  }

  canvas.addEventListener('click', (e) => {
    const st = viewer.state, s = viewer.scene;
    if (!st || !s || !viewer.frame) return;
    const rect = canvas.getBoundingClientRect();
    const px = (e.clientX - rect.left) * (canvas.width / rect.width);
    const py = (e.clientY - rect.top) * (canvas.height / rect.height);
    const [wx, wy] = viewer.toWorld(px, py);
    let best = -1, bestD = Infinity;
    st.robots.forEach((r, i) => {
      if (!r.released) return;
      const d = Math.hypot(r.x - wx, r.y - wy);
      const g = s.groups[r.group];
      const reach = Math.max(g.radius * 1.5, 8 * viewer.frame.dpr / viewer.frame.scale);
      if (d <= reach && d < bestD) { best = i; bestD = d; }
    });
    select(best);
  });
  $('i-close').addEventListener('click', () => select(-1));

  async function loadScene() {
    viewer.scene = await api('GET', '/api/scene');
    $('scenario-name').textContent = viewer.scene.scenario;
    $('scenario-desc').textContent = viewer.scene.description || '';
    document.title = 'Formica: ' + viewer.scene.scenario;
    fit();
  }

  async function show(st) {
    const fresh = !viewer.scene || viewer.scene.generation !== st.generation;
    if (fresh) await loadScene();
    viewer.state = st;
    panel();
    draw();
    await refreshSeries(fresh);
    await inspect();
  }

  // ---- polling ----
  let timer = null;
  let inflight = false;
  async function poll() {
    clearTimeout(timer);
    if (inflight) return;
    inflight = true;
    try {
      await show(await api('GET', '/api/state' + query()));
      showError('');
    } catch (e) {
      showError('server unreachable: ' + e.message);
    } finally {
      inflight = false;
      const playing = viewer.state && viewer.state.playing;
      timer = setTimeout(poll, playing ? 100 : 500);
    }
  }

  async function control(path) {
    try {
      const sep = path.includes('?') ? '&' : '?';
      const q = query();
      await show(await api('POST', path + (q ? sep + q.slice(1) : '')));
      showError('');
    } catch (e) {
      showError(e.message);
    }
    poll();
  }

  $('play').addEventListener('click', () => {
    control(viewer.state && viewer.state.playing ? '/api/pause' : '/api/play');
  });
  $('step').addEventListener('click', () => control('/api/step?n=1'));
  $('speed').addEventListener('change', () => control('/api/speed?x=' + encodeURIComponent($('speed').value)));
  $('restart').addEventListener('click', () => {
    const v = $('seed').value.trim();
    if (v !== '' && !/^\d+$/.test(v)) { showError('the seed must be a whole number'); return; }
    control('/api/restart' + (v === '' ? '' : '?seed=' + v));
  });
  $('newseed').addEventListener('click', () => {
    const cur = viewer.state ? viewer.state.seed : 0;
    control('/api/restart?seed=' + (cur + 1));
  });
  for (const id of ['show-rays', 'show-zones']) $(id).addEventListener('change', poll);
  $('show-path').addEventListener('change', draw);
  window.addEventListener('resize', () => { fit(); draw(); });
  document.addEventListener('keydown', (e) => {
    if (e.target instanceof HTMLInputElement || e.target instanceof HTMLSelectElement) return;
    if (e.key === ' ') { e.preventDefault(); $('play').click(); }
    if (e.key === 's' || e.key === 'ArrowRight') $('step').click();
  });

  poll();
})();
