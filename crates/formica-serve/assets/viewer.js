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
    frame: null,
    toPixel(x, y) {
      const f = viewer.frame;
      if (!f) return [0, 0];
      return [(x - f.minX) * f.scale, f.h - (y - f.minY) * f.scale];
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
    const goal = s.lights.find((l) => l.goal);
    if (goal && s.goal_radius) {
      const [gx, gy] = P(goal.at);
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

    for (const l of s.lights) {
      const [x, y] = P(l.at);
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
      if (i === viewer.highlight) {
        ctx.beginPath();
        ctx.arc(x, y, rad + 4 * lw, 0, 2 * Math.PI);
        ctx.strokeStyle = '#e000a0';
        ctx.lineWidth = 2 * lw;
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
    $('s-path').textContent = st.object_path_m.toFixed(3) + ' m';
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
      rows[i].className = i === viewer.highlight ? 'hl' : '';
    }
    document.body.dataset.tick = String(st.tick);
    document.body.dataset.generation = String(st.generation);
  }

  async function loadScene() {
    viewer.scene = await api('GET', '/api/scene');
    $('scenario-name').textContent = viewer.scene.scenario;
    $('scenario-desc').textContent = viewer.scene.description || '';
    document.title = 'Formica: ' + viewer.scene.scenario;
    fit();
  }

  async function show(st) {
    if (!viewer.scene || viewer.scene.generation !== st.generation) await loadScene();
    viewer.state = st;
    panel();
    draw();
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
