// The workbench in a real browser (Debian's Chromium, headless, driven over the DevTools
// protocol by playwright-core: no browser download, and the DevTools client reads the
// canvas and catches downloads, which WebDriver cannot do as simply).
//
//   node e2e/workbench.mjs <phase>
//
// Environment: MESHFLOW_URL (the engine), ARTEFACTS (screenshots, downloads, runs.json),
// BUNNY, SCAN (meshes to upload), REPAIR (repair.json), BAD_MESH (random bytes as .stl),
// optionally BIG_RUN (a finished run of a large result, for the time-to-first-frame figure).
// Phases: `main` (build, run, watch, view, download, failures, reload) and `restarted`
// (history after the engine restarted). Exits non-zero on the first failed expectation.

import { chromium } from 'playwright-core';
import { writeFileSync, readFileSync, mkdirSync } from 'node:fs';
import { join } from 'node:path';
import assert from 'node:assert/strict';

const BASE = process.env.MESHFLOW_URL;
/** The engine's API token, as `meshflow up` prints it in the page's address. */
const API_TOKEN = process.env.API_TOKEN;
const HOME = `${BASE}/#token=${API_TOKEN}`;
const ARTEFACTS = process.env.ARTEFACTS;
const RUN_TIMEOUT = 180_000;
mkdirSync(ARTEFACTS, { recursive: true });

const FLAGS = ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
  '--disable-background-networking', '--disable-component-update', '--disable-sync',
  // WebGL without a GPU: SwiftShader, in software.
  '--use-angle=swiftshader', '--enable-unsafe-swiftshader'];

const log = (...parts) => console.log(`[workbench ${((performance.now()) / 1000).toFixed(1)}s]`, ...parts);

async function shot(page, name) {
  await page.screenshot({ path: join(ARTEFACTS, `${name}.png`), fullPage: true });
}

/** Waits for the run view to show a final status; that status. */
async function finalStatus(page) {
  const status = page.getByTestId('run-status');
  await page.waitForFunction(() => {
    const s = document.querySelector('[data-testid=run-status]')?.dataset.status;
    return ['completed', 'failed', 'cancelled', 'interrupted'].includes(s);
  }, null, { timeout: RUN_TIMEOUT });
  return status.getAttribute('data-status');
}

async function runId(page) {
  return page.getByTestId('run-status').getAttribute('data-run');
}

/** The viewer's canvas has drawn a mesh: some pixels differ from the background. */
async function canvasNotBlank(page, label) {
  await page.waitForFunction((shown) => document.querySelector('[data-testid=viewer]')?.dataset.shown === shown, label, { timeout: RUN_TIMEOUT });
  const share = await page.evaluate(() => {
    const canvas = document.querySelector('[data-testid=viewer]');
    const copy = document.createElement('canvas');
    copy.width = canvas.width;
    copy.height = canvas.height;
    const context = copy.getContext('2d');
    context.drawImage(canvas, 0, 0);
    const pixels = context.getImageData(0, 0, copy.width, copy.height).data;
    const [r, g, b] = [pixels[0], pixels[1], pixels[2]];
    let differing = 0;
    for (let i = 0; i < pixels.length; i += 4) {
      if (Math.abs(pixels[i] - r) + Math.abs(pixels[i + 1] - g) + Math.abs(pixels[i + 2] - b) > 30) differing += 1;
    }
    return differing / (pixels.length / 4);
  });
  log(`viewer shows ${label}: ${(share * 100).toFixed(1)}% of pixels are mesh`);
  assert.ok(share > 0.01, `the viewer's canvas is blank (${share})`);
}

/** No page-level sideways scrolling; the page as a screenshot at `width`×`height`. */
async function narrow(page, width, height, name) {
  await page.setViewportSize({ width, height });
  await page.waitForTimeout(300);
  const fits = await page.evaluate(() => ({ scroll: document.documentElement.scrollWidth, inner: innerWidth }));
  log(`at ${width}×${height}: scrollWidth ${fits.scroll}, innerWidth ${fits.inner}`);
  assert.ok(fits.scroll <= fits.inner, `the page scrolls sideways at ${width} px (${fits.scroll} > ${fits.inner})`);
  await shot(page, name);
}

/** Pairs of the bytes chart's labels whose boxes overlap by more than a pixel. */
async function chartOverlaps(page) {
  return page.evaluate(() => {
    const boxes = [...document.querySelectorAll('[data-testid=bytes-chart] text')].map((t) => [t.textContent, t.getBoundingClientRect()]);
    const clash = [];
    boxes.forEach(([x, a], i) => boxes.slice(i + 1).forEach(([y, b]) => {
      const w = Math.min(a.right, b.right) - Math.max(a.left, b.left);
      const h = Math.min(a.bottom, b.bottom) - Math.max(a.top, b.top);
      if (w > 1 && h > 1) clash.push(`${x} / ${y}`);
    }));
    return clash;
  });
}

/** The login against the engine's real token check, and an unreachable engine, in words. */
async function login(page) {
  // A wrong token in the address goes as a bearer header; the engine refuses it, the page asks.
  const asked = page.waitForRequest((r) => r.url().endsWith('/services'));
  await page.goto(`${BASE}/#token=not-the-token`);
  assert.equal((await asked).headers().authorization, 'Bearer not-the-token', 'the token goes as a bearer header');
  assert.equal(await page.evaluate(() => location.hash), '', 'the token left the address bar');
  await page.getByTestId('login').waitFor();
  await page.getByTestId('login-token').fill(API_TOKEN);
  const again = page.waitForResponse((r) => r.url().endsWith('/services'));
  await page.getByTestId('login-submit').click();
  assert.equal((await again).status(), 200, 'the engine takes the right token from the form');
  // The API token is the user `default`, an admin; the page says who is signed in.
  await page.waitForFunction(() => document.querySelector('[data-testid=signed-in-user]')?.dataset.user === 'default');
  assert.match(await page.getByTestId('signed-in-user').textContent(), /default/, 'the signed-in user shows');
  await page.route('**/services', (route) => route.abort('connectionrefused'));
  await page.reload();
  await page.getByTestId('engine-banner').getByText('cannot be reached').waitFor();
  await shot(page, '00-engine-unreachable');
  await page.unroute('**/services');
  await page.evaluate(() => sessionStorage.clear());
}

async function main(page) {
  const runs = {};
  await login(page);
  // A fresh load (not a same-page fragment change), so the page reads the token anew.
  await page.goto('about:blank');
  await page.goto(HOME);
  // On opening: the empty workflow is said neutrally, the icon needs no token, and the step
  // picker starts at a harmless common service.
  await page.getByTestId('validation').getByText('Add a step to begin').waitFor();
  assert.ok(!(await page.getByTestId('validation').getAttribute('class')).includes('error'), 'no error before the user did anything');
  const icon = await page.request.get(`${BASE}/favicon.ico`);
  assert.equal(icon.status(), 200, `GET /favicon.ico answered ${icon.status()}`);
  await page.waitForFunction(() => document.querySelector('[data-testid=add-step-service]')?.value);
  assert.equal(await page.getByTestId('add-step-service').inputValue(), 'remove-smallest-components');
  await page.getByTestId('tab-catalogue').click();
  await page.getByTestId('service-list').locator('[data-service=fill-holes]').waitFor();
  const catalogue = await page.getByTestId('service-list').textContent();
  for (const expected of ['laplacian-smoothing', 'iterations', 'cotangent', 'Offered by']) {
    assert.ok(catalogue.includes(expected), `the catalogue lacks ${expected}`);
  }
  assert.match(catalogue, /Plugin digest\(s\): [0-9a-f]{16}…/, 'the catalogue names the plugin digests');
  await shot(page, '01-catalogue');

  // The repair workflow by clicks only.
  await page.getByTestId('tab-build').click();
  for (const service of ['remove-smallest-components', 'laplacian-smoothing', 'fill-holes', 'remove-degenerate-triangles']) {
    await page.getByTestId('add-step-service').selectOption(service);
    await page.getByTestId('add-step').click();
  }
  // The picker keeps the last choice; focus went to the new step.
  assert.equal(await page.getByTestId('add-step-service').inputValue(), 'remove-degenerate-triangles');
  assert.equal(await page.evaluate(() => document.activeElement?.closest('[data-testid=step-card]')?.dataset.path), 'steps[3]',
    'focus is on the step just added');
  await page.locator('[data-path="steps[1]"] [data-param=iterations]').fill('1');
  await page.getByText('The engine accepts this workflow.').waitFor();
  const built = JSON.parse(await page.getByTestId('workflow-json').inputValue());
  const repair = JSON.parse(readFileSync(process.env.REPAIR, 'utf8'));
  assert.deepEqual(built, repair, 'the clicked workflow is repair.json');
  // A bad parameter is refused with its step path, as the engine would.
  await page.locator('[data-path="steps[1]"] [data-param=iterations]').fill('0');
  await page.getByTestId('validation').getByText('steps[1]').waitFor();
  assert.ok(await page.locator('.card.invalid[data-path="steps[1]"]').count() === 1, 'the bad step is marked');
  await shot(page, '02-builder-invalid');
  await page.locator('[data-path="steps[1]"] [data-param=iterations]').fill('1');
  await page.getByText('The engine accepts this workflow.').waitFor();
  await shot(page, '03-builder');

  await page.getByTestId('mesh-file').setInputFiles(process.env.BUNNY);
  await page.getByTestId('run').click();
  await page.getByTestId('step-row').first().waitFor({ timeout: RUN_TIMEOUT });
  assert.equal(await finalStatus(page), 'completed');
  runs.bunny = await runId(page);
  assert.equal(await page.getByTestId('step-row').count(), 4);
  await canvasNotBlank(page, 'result');
  await shot(page, '04-run-bunny');

  // Every way a step can travel is offered, replays included.
  const modes = await page.getByTestId('transfer').locator('option').allTextContents();
  assert.deepEqual(modes, ['auto', 'correction', 'replay', 'full']);
  // The same run with `transfer: full`: what was sent says so.
  await page.getByTestId('transfer').selectOption('full');
  await page.getByTestId('run').click();
  await page.waitForFunction((last) => document.querySelector('[data-testid=run-status]')?.dataset.run !== last, runs.bunny);
  assert.equal(await finalStatus(page), 'completed');
  runs.bunnyFull = await runId(page);
  const sentCells = await page.locator('td.sent').allTextContents();
  assert.ok(sentCells.some((c) => c.includes(': full ')) && !sentCells.some((c) => c.includes(': correction ')), sentCells.join(' | '));
  await page.getByTestId('transfer').selectOption('auto');

  // A grid and load-only placement go into the workflow; an impossible grid is refused by
  // the engine by name; back at the defaults, both keys leave the workflow again.
  const workflowJson = async () => JSON.parse(await page.getByTestId('workflow-json').inputValue());
  await page.getByTestId('quantize').fill('30');
  await page.getByTestId('validation').getByText('quantize').waitFor();
  await page.getByTestId('quantize').fill('16');
  await page.getByTestId('placement').selectOption('load');
  await page.getByText('The engine accepts this workflow.').waitFor();
  const keyed = await workflowJson();
  assert.equal(keyed.quantize, 16);
  assert.equal(keyed.placement, 'load');
  await page.getByTestId('run').click();
  await page.waitForFunction((last) => document.querySelector('[data-testid=run-status]')?.dataset.run !== last, runs.bunnyFull);
  assert.equal(await finalStatus(page), 'completed');
  await page.getByTestId('quantize').fill('');
  await page.getByTestId('placement').selectOption('link');
  const plain = await workflowJson();
  assert.ok(!('quantize' in plain) && !('placement' in plain), JSON.stringify(plain));

  // repair.json from a file, on an uploaded scan; steps arrive while it runs.
  await page.getByTestId('clear-workflow').click();
  await page.getByTestId('workflow-file').setInputFiles(process.env.REPAIR);
  await page.getByTestId('json-note').getByText('loaded repair.json').waitFor();
  await page.getByText('The engine accepts this workflow.').waitFor();
  assert.deepEqual(JSON.parse(await page.getByTestId('workflow-json').inputValue()), repair);
  await page.getByTestId('mesh-file').setInputFiles(process.env.SCAN);
  await page.getByTestId('run').click();
  await page.waitForFunction((last) => {
    const run = document.querySelector('[data-testid=run-status]')?.dataset.run;
    return run && run !== last;
  }, runs.bunnyFull);
  const seen = new Set();
  for (;;) {
    const status = await page.getByTestId('run-status').getAttribute('data-status').catch(() => null);
    seen.add(`${status}:${await page.getByTestId('step-row').count()}`);
    if (['completed', 'failed'].includes(status)) break;
    await page.waitForTimeout(50);
  }
  log('scan run, status:rows seen', [...seen].join(' '));
  assert.ok([...seen].some((s) => /^running:[1-3]$/.test(s)), 'steps arrived one by one while running');
  assert.equal(await finalStatus(page), 'completed');
  runs.scan = await runId(page);
  await canvasNotBlank(page, 'result');
  await page.getByTestId('show-input').click();
  await canvasNotBlank(page, 'input');
  await page.getByTestId('view-side').click();
  await page.waitForTimeout(200);
  await shot(page, '05-run-scan-side-by-side');
  const [download] = await Promise.all([page.waitForEvent('download'), page.getByTestId('download-ply').click()]);
  const name = download.suggestedFilename();
  assert.match(name, /-result\.ply$/);
  await download.saveAs(join(ARTEFACTS, name));
  log('downloaded', name);
  runs.download = name;

  // A WHILE from the examples: check values rounded, whether each condition held.
  await page.getByTestId('example-smooth-while-unstable').click();
  await page.getByText('The engine accepts this workflow.').waitFor();
  await page.getByTestId('mesh-file').setInputFiles(process.env.BUNNY);
  await page.getByTestId('run').click();
  await page.waitForFunction((last) => document.querySelector('[data-testid=run-status]')?.dataset.run !== last, runs.scan);
  assert.equal(await finalStatus(page), 'completed');
  runs.loop = await runId(page);
  const values = await page.getByTestId('step-value').allTextContents();
  assert.ok(values.some((v) => v.includes('✓ condition held')), values.join(' | '));
  assert.ok(values.some((v) => v.includes('✗ condition did not hold')), values.join(' | '));
  assert.ok(values.every((v) => !/\d\.\d{5}/.test(v)), `values are rounded: ${values.join(' | ')}`);
  await shot(page, '05b-run-while');
  assert.deepEqual(await chartOverlaps(page), [], 'the bytes chart\'s labels do not overlap');

  // Narrow windows: no sideways scrolling, the builder stacked, step rows as cards.
  await narrow(page, 1024, 700, '12-width-1024');
  await narrow(page, 390, 844, '13-width-390');
  const layout = await page.evaluate(() => ({
    json: document.querySelector('[data-testid=workflow-json]').getBoundingClientRect().width,
    row: getComputedStyle(document.querySelector('[data-testid=step-row]')).display,
  }));
  log('at 390 px', JSON.stringify(layout));
  assert.ok(layout.json > 300, `the JSON box is ${layout.json} px wide at 390 px`);
  assert.equal(layout.row, 'grid', 'step rows are cards at 390 px');
  await page.getByTestId('step-row').first().scrollIntoViewIfNeeded();
  await page.screenshot({ path: join(ARTEFACTS, '13b-width-390-steps.png') });
  await page.setViewportSize({ width: 1400, height: 1000 });

  // A WHILE false at once runs no filter: its result is its input, shown and downloaded.
  await page.getByTestId('workflow-json').fill(JSON.stringify({ steps: [{ while: { check: 'component-count', op: '>', value: 1000000 },
    'max-iterations': 3, do: [{ run: 'laplacian-smoothing' }] }] }));
  await page.getByText('The engine accepts this workflow.').waitFor();
  await page.getByTestId('run').click();
  await page.waitForFunction((last) => document.querySelector('[data-testid=run-status]')?.dataset.run !== last, runs.loop);
  assert.equal(await finalStatus(page), 'completed');
  runs.noFilter = await runId(page);
  await canvasNotBlank(page, 'result');
  const [unchanged] = await Promise.all([page.waitForEvent('download'), page.getByTestId('download-ply').click()]);
  assert.match(unchanged.suggestedFilename(), /^bunny-result\.ply$/);
  await unchanged.saveAs(join(ARTEFACTS, unchanged.suggestedFilename()));
  // "Before" loads the input when chosen; "Side by side" shows both.
  await page.getByTestId('view-before').click();
  await canvasNotBlank(page, 'input');
  await page.getByTestId('view-side').click();
  assert.equal(await page.getByTestId('viewer').getAttribute('data-mode'), 'side');
  // The canvas takes focus; arrows orbit and + zooms.
  await page.getByTestId('viewer').focus();
  const camera = () => page.getByTestId('viewer').getAttribute('data-camera');
  const before = await camera();
  await page.keyboard.press('ArrowLeft');
  const orbited = await camera();
  assert.notEqual(orbited, before, 'ArrowLeft orbits');
  await page.keyboard.press('+');
  assert.notEqual(await camera(), orbited, '+ zooms');
  await shot(page, '05d-no-filter-side-by-side');

  // A WHILE and an IF by clicks, nested: the builder's own JSON, accepted by the engine.
  await page.getByTestId('clear-workflow').click();
  await page.getByTestId('add-while').click();
  await page.locator('[data-path="steps[0]"] .add-bar button', { hasText: '+ IF' }).click();
  await page.locator('[data-path="steps[0].do[0]"] .branch').first().locator('.add-bar button', { hasText: '+ step' }).click();
  await page.getByText('The engine accepts this workflow.').waitFor();
  const nested = JSON.parse(await page.getByTestId('workflow-json').inputValue());
  assert.ok(nested.steps[0].while && nested.steps[0].do[0].if && nested.steps[0].do[0].then[0].run, JSON.stringify(nested));
  await shot(page, '05c-builder-nested');

  // An input from an origin the engine does not fetch from: the refusal says what to do.
  await page.getByTestId('mesh-file').setInputFiles([]);
  await page.getByTestId('input-url').fill('http://203.0.113.7/scan.ply');
  await page.getByTestId('run').click();
  await page.getByTestId('run-note').getByText('--allow-input-from').waitFor();

  // Failures show failed, in words, never "running" forever; a new run never mixes with the last.
  await page.getByTestId('input-url').fill('http://127.0.0.1:9/nothing.ply');
  await page.getByTestId('run').click();
  assert.equal(await finalStatus(page), 'failed');
  runs.deadPort = await runId(page);
  assert.equal(await page.getByTestId('step-row').count(), 0, 'no rows of the previous run');
  assert.ok((await page.getByTestId('run-error').textContent()).length > 10);
  await shot(page, '06-failed-dead-port');
  await page.getByTestId('input-url').fill('');
  await page.getByTestId('mesh-file').setInputFiles(process.env.BAD_MESH);
  await page.getByTestId('run').click();
  assert.equal(await finalStatus(page), 'failed');
  runs.badMesh = await runId(page);
  assert.equal(await page.getByTestId('viewer').getAttribute('data-shown'), null, 'no mesh of an earlier run is shown');
  const badError = await page.getByTestId('run-error').textContent();
  log('bad upload:', badError);
  assert.ok(badError.includes('"random.stl"'), `the error names the uploaded file: ${badError}`);
  assert.ok(!badError.includes('/inputs/'), `the error does not show the stored file: ${badError}`);
  await shot(page, '07-failed-bad-mesh');

  // Values from users and hosts are text: markup in a service name stays inert.
  const hostile = '<img src=x onerror="window.__xss=1">x" onmouseover="window.__xss=2';
  await page.getByTestId('workflow-json').fill(JSON.stringify({ steps: [{ run: hostile }] }));
  await page.getByTestId('validation').getByText('Not valid').waitFor();
  assert.ok((await page.getByTestId('validation').textContent()).includes('<img src=x'), 'the name shows as text');
  assert.equal(await page.locator('#app img, [onmouseover]').count(), 0, 'no element was made from the name');
  assert.equal(await page.evaluate(() => window.__xss), undefined);

  // An empty workflow is refused before it runs, in words.
  await page.getByTestId('clear-workflow').click();
  await page.getByTestId('validation').getByText('at least one step').waitFor();
  await page.getByTestId('run').click();
  await page.getByTestId('run-note').getByText('at least one step').waitFor();
  assert.equal(await page.getByTestId('run-status').getAttribute('data-status'), 'refused', 'no run is shown as starting');

  // A plugin uploaded to a chosen host through the engine, with the host's token.
  await page.getByTestId('tab-plugins').click();
  await page.getByTestId('plugin-token').fill('wrong');
  await page.getByTestId('plugin-file').setInputFiles(process.env.PLUGIN);
  await page.getByTestId('plugin-upload').click();
  await page.getByTestId('plugin-answer').getByText('refused the upload token').waitFor();
  assert.equal(await page.getByTestId('login').isHidden(), true, "the host's refusal is not a login prompt");
  await page.getByTestId('plugin-token').fill(process.env.UPLOAD_TOKEN);
  await page.getByTestId('plugin-upload').click();
  await page.getByTestId('plugin-answer').getByText('laplacian-smoothing').waitFor();
  // The same bytes again: the host has them, and the page says so.
  await page.getByTestId('plugin-upload').click();
  await page.getByTestId('plugin-answer').getByText('already').waitFor();
  await shot(page, '07b-plugin-uploaded');
  await page.getByTestId('tab-build').click();

  // History survives a reload.
  await page.reload();
  await page.getByTestId('tab-history').click();
  for (const id of [runs.bunny, runs.scan, runs.deadPort, runs.badMesh]) {
    await page.locator(`[data-testid=history-row][data-run="${id}"]`).waitFor();
  }
  // Rows say when, which input, what workflow, how long; the filter narrows them.
  const bunnyRow = page.locator(`[data-testid=history-row][data-run="${runs.bunny}"]`);
  const scanRow = page.locator(`[data-testid=history-row][data-run="${runs.scan}"]`);
  const bunnyText = await bunnyRow.textContent();
  assert.ok(bunnyText.includes('bunny.obj') && bunnyText.includes('remove-smallest-components → laplacian-smoothing'), bunnyText);
  assert.ok(!(await bunnyRow.locator('td.when').textContent()).includes('—'), 'the row says when');
  await page.getByTestId('history-filter').fill('scan.ply');
  await scanRow.waitFor();
  assert.equal(await bunnyRow.isHidden(), true, 'the filter hides the bunny run');
  await shot(page, '08-history');
  await page.getByTestId('history-filter').fill('');
  writeFileSync(join(ARTEFACTS, 'runs.json'), JSON.stringify(runs, null, 2));
}

async function restarted(page) {
  const runs = JSON.parse(readFileSync(join(ARTEFACTS, 'runs.json'), 'utf8'));
  await page.goto(HOME);
  await page.getByTestId('tab-history').click();
  const expected = { bunny: 'completed', scan: 'completed', deadPort: 'failed', badMesh: 'failed' };
  for (const [key, status] of Object.entries(expected)) {
    const row = page.locator(`[data-testid=history-row][data-run="${runs[key]}"]`);
    await row.waitFor();
    assert.equal(await row.getAttribute('data-status'), status, key);
  }
  // Open a finished run from history: the same view, its result in the viewer.
  await page.locator(`[data-testid=history-row][data-run="${runs.scan}"] [data-testid=history-open]`).click();
  assert.equal(await finalStatus(page), 'completed');
  assert.ok(await page.getByTestId('step-row').count() >= 4);
  await canvasNotBlank(page, 'result');
  await shot(page, '09-after-restart');

  // Compare two runs' records; re-run one with its workflow and input.
  await page.getByTestId('tab-history').click();
  for (const id of [runs.bunny, runs.bunnyFull]) {
    await page.locator(`[data-testid=history-row][data-run="${id}"] input[type=checkbox]`).check();
  }
  await page.getByTestId('history-compare').click();
  await page.getByTestId('comparison').locator('table.compare').waitFor();
  const comparison = await page.getByTestId('comparison').textContent();
  assert.ok(comparison.includes('bytes sent between hosts') && comparison.includes('transfer: full'), comparison);
  await shot(page, '10-compare');
  await page.locator(`[data-testid=history-row][data-run="${runs.deadPort}"] [data-testid=history-rerun]`).click();
  await page.getByTestId('run-note').getByText('Loaded the run').waitFor();
  assert.equal(await page.getByTestId('input-url').inputValue(), 'http://127.0.0.1:9/nothing.ply');
  await page.getByTestId('run').click();
  await page.waitForFunction((last) => document.querySelector('[data-testid=run-status]')?.dataset.run !== last, runs.scan);
  assert.equal(await finalStatus(page), 'failed');
}

/** Opens the page on a finished run with a large result: time from navigation to its first frame. */
async function big(page) {
  // Long tasks of the main thread, recorded from before the page loads.
  await page.addInitScript(() => {
    window.__longTasks = [];
    new PerformanceObserver((list) => {
      for (const entry of list.getEntries()) window.__longTasks.push({ start: Math.round(entry.startTime), ms: Math.round(entry.duration) });
    }).observe({ type: 'longtask', buffered: true });
  });
  await page.goto(`${BASE}/?run=${process.env.BIG_RUN}#token=${API_TOKEN}`);
  await page.waitForFunction(() => document.querySelector('[data-testid=viewer]')?.dataset.shown === 'result', null, { timeout: RUN_TIMEOUT });
  const figures = await page.evaluate(() => ({ ...document.querySelector('[data-testid=viewer]').dataset }));
  assert.ok(Number(figures.vertices) > 900_000, `the large result has ${figures.vertices} vertices`);
  log('large result', JSON.stringify(figures));
  await page.waitForFunction(() => document.querySelector('[data-testid=viewer]')?.dataset.boundaryEdges !== undefined, null, { timeout: RUN_TIMEOUT });
  await page.waitForTimeout(300);
  const tasks = await page.evaluate(() => window.__longTasks);
  // While the mesh is fetched and decoded (the worker's job) the page must stay responsive.
  // Drawing a frame of 2M triangles is the GPU's job; this browser has none (SwiftShader
  // draws in software on the main thread), so frame tasks are reported, not held to 200 ms.
  const [from, to] = [Number(figures.loadStartedMs), Number(figures.decodedAtMs)];
  const loading = tasks.filter((t) => t.start + t.ms >= from && t.start <= to);
  const longest = Math.max(0, ...loading.map((t) => t.ms));
  const drawing = tasks.filter((t) => t.start > to).map((t) => t.ms);
  log('long tasks (all, ms):', JSON.stringify(tasks), `while the large mesh loaded: ${loading.length}, longest ${longest} ms; drawing (software): ${JSON.stringify(drawing)}`);
  figures.longTasks = tasks;
  figures.longestWhileLoadingMs = longest;
  assert.ok(to > from, `decoded at ${to} ms, asked at ${from} ms`);
  // What this guards against, decoding 1M vertices on the main thread, holds it for seconds;
  // on a 2-core machine under test load one task of the page's own (a record's render, a
  // collection) can pass 200 ms, which CI saw once at 227 ms. So: at most one over 200 ms,
  // none over 400.
  const over200 = loading.filter((t) => t.ms > 200).length;
  assert.ok(longest <= 400 && over200 <= 1, `main-thread tasks of ${JSON.stringify(loading)} ms while the large mesh loaded`);
  // The frame that draws it is issued within 3 s of asking (issue 31); how long the
  // software rasteriser then takes is in the drawing tasks logged above.
  assert.ok(Number(figures.firstFrameMs) <= 3000, `first frame ${figures.firstFrameMs} ms after asking`);
  await canvasNotBlank(page, 'result');
  await shot(page, '11-large-result');
  writeFileSync(join(ARTEFACTS, 'first-frame.json'), JSON.stringify(figures, null, 2));

  // A run on a coloured PLY: what its input and result carry, what the file held that the
  // run does not keep, and the result drawn in its own colours.
  await page.goto(`${BASE}/?run=${process.env.COLOURED_RUN}#token=${API_TOKEN}`);
  const notKept = page.getByTestId('input-not-kept');
  await notKept.waitFor({ timeout: RUN_TIMEOUT });
  assert.match(await notKept.innerText(), /Not kept from the input file: element 'edge' \(1 records\)/);
  assert.match(await page.getByTestId('input-attributes').innerText(), /vertex color \(4 × u8\)/);
  assert.match(await page.getByTestId('result-attributes').innerText(), /carries vertex color/);
  await page.waitForFunction(() => document.querySelector('[data-testid=viewer]')?.dataset.shown === 'result', null, { timeout: RUN_TIMEOUT });
  const viewer = await page.evaluate(() => ({ ...document.querySelector('[data-testid=viewer]').dataset }));
  assert.equal(viewer.vertexColors, 'yes', 'the viewer draws the mesh in its colours');
  assert.match(await page.getByTestId('viewer-status').innerText(), /carries vertex color \(4 × u8\)/);
  await shot(page, '12-coloured-result');

  // A textured OBJ chosen with its image: the run keeps its per-corner texture coordinates
  // and material library, and the result is drawn with the image, which never left here.
  await page.goto(`${BASE}/#token=${API_TOKEN}`);
  await page.getByTestId('workflow-json').fill(JSON.stringify({ steps: [{ run: 'remove-degenerate-triangles' }] }));
  await page.getByText('The engine accepts this workflow.').waitFor();
  await page.getByTestId('mesh-file').setInputFiles([process.env.TEXTURED_OBJ, process.env.TEXTURE_PNG]);
  await page.getByTestId('run').click();
  assert.equal(await finalStatus(page), 'completed');
  assert.match(await page.getByTestId('input-attributes').innerText(), /corner texcoord \(2 × f32\)/);
  await page.waitForFunction(() => document.querySelector('[data-testid=viewer]')?.dataset.textureLoaded === 'checker-skin.png', null, { timeout: RUN_TIMEOUT });
  await canvasNotBlank(page, 'result');
  await shot(page, '13-textured-result');
}

const phases = { main, restarted, big };
const phase = phases[process.argv[2]];
assert.ok(phase, `phase: one of ${Object.keys(phases).join(', ')}`);
const browser = await chromium.launch({ executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium', args: FLAGS });
const page = await (await browser.newContext({ acceptDownloads: true, viewport: { width: 1400, height: 1000 } })).newPage();
page.on('pageerror', (error) => log('page error:', error.message));
try {
  await phase(page);
  log(`phase ${process.argv[2]}: ok`);
} catch (error) {
  await shot(page, `failed-${process.argv[2]}`).catch(() => {});
  throw error;
} finally {
  await browser.close();
}
