// End-to-end test of `formica serve` in headless Chromium (Debian's, driven by playwright-core).
// Run by e2e/run.sh, which starts the servers and passes their addresses: FORMICA_URL (a live
// scenario) and FORMICA_REPLAY_URL (`formica serve --db smoke.db --trial N`, N in
// FORMICA_REPLAY_TRIAL).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { mkdtempSync, mkdirSync, rmSync, statSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

const BASE = (process.env.FORMICA_URL || '').replace(/\/$/, '');
const REPLAY = (process.env.FORMICA_REPLAY_URL || '').replace(/\/$/, '');
const TRIAL = Number(process.env.FORMICA_REPLAY_TRIAL || '3');
const OUT = process.env.E2E_OUT || join(dirname(fileURLToPath(import.meta.url)), 'out');
const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';

let context;
let page;
let profile;
const problems = [];
const foreign = [];

before(async () => {
  assert.ok(BASE.startsWith('http://127.0.0.1:'), 'FORMICA_URL must name the loopback server');
  assert.ok(REPLAY.startsWith('http://127.0.0.1:'), 'FORMICA_REPLAY_URL must name the loopback replay server');
  profile = mkdtempSync(join(tmpdir(), 'formica-e2e-profile-'));
  context = await chromium.launchPersistentContext(profile, {
    executablePath: CHROMIUM,
    headless: true,
    viewport: { width: 1280, height: 860 },
    args: [
      '--no-sandbox',
      '--disable-gpu',
      '--disable-background-networking',
      '--disable-component-update',
      '--no-first-run',
      '--disable-quic',
      '--disable-sync',
    ],
  });
  page = context.pages()[0] || (await context.newPage());
  page.on('console', (m) => { if (m.type() === 'error') problems.push('console: ' + m.text()); });
  page.on('pageerror', (e) => problems.push('page error: ' + e.message));
  page.on('request', (r) => {
    const u = r.url();
    if (!u.startsWith(BASE + '/') && !u.startsWith(REPLAY + '/') && !u.startsWith('data:')) foreign.push(u);
  });
});

after(async () => {
  if (context) await context.close();
  if (profile) rmSync(profile, { recursive: true, force: true });
});

const tickShown = () => page.locator('#s-tick').textContent();

// Waits until the viewer shows a tick equal to (`eq`) or at least (`ge`) `n`.
async function waitTick(op, n, what) {
  await page.waitForFunction(
    ([op, n]) => {
      const v = window.formicaViewer;
      if (!v || !v.state) return false;
      return op === 'eq' ? v.state.tick === n : v.state.tick >= n;
    },
    [op, n],
    { timeout: 15000 },
  ).catch((e) => { throw new Error('timed out waiting for ' + what + ': ' + e.message); });
}

test('the page loads offline and draws the robots', async () => {
  const resp = await page.goto(BASE + '/');
  assert.equal(resp.status(), 200);
  await page.waitForFunction(() => window.formicaViewer && window.formicaViewer.frames > 0, null, { timeout: 15000 });
  assert.equal(await page.locator('#scenario-name').textContent(), 'seed-transport');

  // DOM: the canvas says how many robots it drew, and the panel lists them.
  const drawn = Number(await page.locator('#view').getAttribute('data-robots-drawn'));
  assert.equal(drawn, 20);
  assert.equal(await page.locator('#robots tbody tr').count(), 20);

  // Pixels: every robot's centre is painted, not background.
  const painted = await page.evaluate(() => {
    const v = window.formicaViewer;
    const ctx = document.getElementById('view').getContext('2d');
    return v.state.robots.map((r) => {
      const [x, y] = v.toPixel(r.x, r.y);
      const d = ctx.getImageData(Math.round(x), Math.round(y), 1, 1).data;
      return !(d[0] === 250 && d[1] === 250 && d[2] === 247);
    });
  });
  assert.equal(painted.length, 20);
  assert.ok(painted.every(Boolean), 'some robot centre is background: ' + JSON.stringify(painted));
  // The goal light is drawn too.
  const goalPainted = await page.evaluate(() => {
    const v = window.formicaViewer;
    const g = v.scene.lights.find((l) => l.goal);
    const [x, y] = v.toPixel(g.at[0], g.at[1]);
    const d = document.getElementById('view').getContext('2d').getImageData(Math.round(x), Math.round(y), 1, 1).data;
    return [d[0], d[1], d[2]];
  });
  assert.deepEqual(goalPainted, [250, 200, 0]);
});

test('stepping advances the simulation and changes what is shown', async () => {
  if ((await page.locator('#play').textContent()) === 'Pause') await page.click('#play');
  const t0 = Number(await tickShown());
  const before = await page.evaluate(() => window.formicaViewer.state.robots.map((r) => [r.x, r.y, r.theta]));
  const pixelsBefore = await page.evaluate(() => document.getElementById('view').toDataURL());
  for (let k = 1; k <= 5; k++) {
    await page.click('#step');
    await waitTick('eq', t0 + k, `tick ${t0 + k}`);
  }
  assert.equal(Number(await tickShown()), t0 + 5);
  assert.match(await page.locator('#s-time').textContent(), /^0\.5 s of \d+ s$/);
  const after = await page.evaluate(() => window.formicaViewer.state.robots.map((r) => [r.x, r.y, r.theta]));
  const moved = after.filter((p, i) => Math.hypot(p[0] - before[i][0], p[1] - before[i][1]) > 1e-4).length;
  assert.ok(moved >= 10, `only ${moved} of 20 robots moved in 5 ticks`);
  const pixelsAfter = await page.evaluate(() => document.getElementById('view').toDataURL());
  assert.notEqual(pixelsAfter, pixelsBefore, 'the canvas changed');
  // Robot states from the controllers are listed.
  const states = await page.locator('#robots tbody tr td:nth-child(2)').allTextContents();
  assert.equal(states.length, 20);
  assert.ok(states.every((s) => s.length > 0 && s !== 'waiting'), JSON.stringify(states));
  assert.equal(await page.locator('#s-outcome').textContent(), 'paused');
});

test('rays, occluded zone, play and restart with a new seed', async () => {
  await page.check('#show-rays');
  await page.waitForFunction(() => {
    const s = window.formicaViewer.state;
    return s.robots.every((r) => Array.isArray(r.rays)) && Array.isArray(s.zones) && s.zones.length > 0;
  }, null, { timeout: 15000 });

  const t0 = Number(await tickShown());
  await page.selectOption('#speed', '8');
  await page.click('#play');
  await waitTick('ge', t0 + 10, 'the clock to run');
  assert.equal(await page.locator('#play').textContent(), 'Pause');
  await page.click('#play');
  await page.waitForFunction(() => !window.formicaViewer.state.playing, null, { timeout: 15000 });

  const firstX = await page.evaluate(() => window.formicaViewer.state.robots[0].x);
  await page.fill('#seed', '5');
  await page.click('#restart');
  await page.waitForFunction(() => window.formicaViewer.state.seed === 5 && window.formicaViewer.state.tick === 0, null, { timeout: 15000 });
  assert.equal(await page.locator('#s-seed').textContent(), '5');
  assert.equal(await tickShown(), '0');
  const newX = await page.evaluate(() => window.formicaViewer.state.robots[0].x);
  assert.notEqual(newX, firstX, 'a new seed places the robots anew');
  await page.click('#newseed');
  await page.waitForFunction(() => window.formicaViewer.state.seed === 6, null, { timeout: 15000 });
  await page.click('#step');
  await waitTick('eq', 1, 'tick 1 after restart');
  mkdirSync(OUT, { recursive: true });
  const file = join(OUT, 'viewer.png');
  await page.screenshot({ path: file, fullPage: true });
  assert.ok(statSync(file).size > 10000, 'screenshot written');
  console.log('# screenshot: ' + file);
});

test('replay: a stored trial loads with its stored outcome and reaches it', async () => {
  const resp = await page.goto(REPLAY + '/');
  assert.equal(resp.status(), 200);
  await page.waitForFunction(() => {
    const v = window.formicaViewer;
    return v && v.frames > 0 && v.scene && v.scene.replay;
  }, null, { timeout: 15000 });
  const rp = await page.evaluate(() => window.formicaViewer.scene.replay);
  assert.equal(rp.label, `trial ${TRIAL} of smoke.db`);
  const banner = await page.locator('#replay').textContent();
  assert.ok(banner.startsWith(`Replay of trial ${TRIAL} of smoke.db, seed ${rp.seed}`), banner);
  assert.ok(banner.includes('Stored outcome: ' + rp.stored_outcome), banner);
  assert.equal(await page.locator('#replay').getAttribute('data-check'), 'running');

  await page.selectOption('#speed', '200');
  await page.click('#play');
  await page.waitForFunction(() => {
    const c = document.getElementById('replay').dataset.check;
    return c === 'match' || c === 'differs';
  }, null, { timeout: 120000 });
  const verdict = await page.locator('#replay').textContent();
  assert.equal(await page.locator('#replay').getAttribute('data-check'), 'match', verdict);
  assert.equal(await page.locator('#s-outcome').textContent(), rp.stored_outcome);
  const st = await page.evaluate(() => window.formicaViewer.state);
  assert.equal(st.tick, rp.stored_ticks);
  assert.equal(st.time_s, rp.stored_time_s);
  // The plots over time were drawn from the run's series.
  await page.waitForFunction(() => Number(document.getElementById('plots').dataset.points) > 10, null, { timeout: 15000 });
});

test('inspect: clicking a robot shows its readings, state and history', async () => {
  const target = await page.evaluate(() => {
    const v = window.formicaViewer;
    const i = v.state.robots.findIndex((r) => r.released);
    const r = v.state.robots[i];
    const [x, y] = v.toPixel(r.x, r.y);
    const c = document.getElementById('view');
    const rect = c.getBoundingClientRect();
    return { i, x: rect.left + x * rect.width / c.width, y: rect.top + y * rect.height / c.height };
  });
  assert.ok(target.i >= 0);
  await page.mouse.click(target.x, target.y);
  await page.waitForFunction((i) => {
    const el = document.getElementById('inspect');
    return !el.hidden && el.dataset.robot === String(i);
  }, target.i, { timeout: 15000 });
  assert.equal(await page.locator('#i-title').textContent(), 'Robot ' + target.i);
  const prox = JSON.parse(await page.locator('#inspect').getAttribute('data-proximity'));
  const light = JSON.parse(await page.locator('#inspect').getAttribute('data-light'));
  assert.equal(prox.length, 8);
  assert.equal(light.length, 8);
  assert.ok(prox.concat(light).every((x) => x >= 0 && x <= 1), JSON.stringify([prox, light]));
  const state = await page.locator('#i-state').textContent();
  const listed = await page.locator(`#robots tbody tr[data-robot="${target.i}"] td:nth-child(2)`).textContent();
  assert.equal(state, listed, 'the inspector and the table agree on the state');
  assert.equal(await page.locator('#i-controller').textContent(), 'occlusion');
  // The bars, the polar plot and the history strip are painted.
  const painted = await page.evaluate(() => ['i-prox', 'i-light', 'i-history'].map((id) => {
    const c = document.getElementById(id);
    const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    let n = 0;
    for (let k = 3; k < d.length; k += 4) if (d[k] > 0) n += 1;
    return n;
  }));
  assert.ok(painted.every((n) => n > 20), 'blank inspector plots: ' + JSON.stringify(painted));
  mkdirSync(OUT, { recursive: true });
  const file = join(OUT, 'replay-inspect.png');
  await page.screenshot({ path: file, fullPage: true });
  assert.ok(statSync(file).size > 10000, 'screenshot written');
  console.log('# screenshot: ' + file);
  // Clicking away from every robot closes the inspector.
  await page.click('#i-close');
  assert.equal(await page.locator('#inspect').isHidden(), true);
});

test('nothing failed or came from elsewhere', async () => {
  assert.deepEqual(problems, []);
  assert.deepEqual(foreign, []);
});
