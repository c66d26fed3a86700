// Drives `motet serve`'s page in Debian's chromium as a person would:
// upload the plotter drawing, check the preview, start, watch the position
// move, pause, resume, emergency stop; then the page on a phone-sized
// screen. Prints one JSON line of what it saw (the Rust test checks it).
// Usage: node page.mjs URL JOB_FILE SCREENSHOT_DIR
import { launch } from "./browser.mjs";

const [url, jobFile, shots] = process.argv.slice(2);
const out = { steps: [] };
const step = (s) => out.steps.push(s);

const browser = await launch();
try {
  const page = await browser.newPage({ viewport: { width: 1280, height: 900 } });
  const errors = [];
  page.on("pageerror", (e) => errors.push(String(e)));
  const t0 = Date.now();
  await page.goto(url);
  await page.waitForSelector("body[data-ready='1']", { timeout: 10000 });
  out.ready_wall_ms = Date.now();
  out.load_ms = out.ready_wall_ms - t0;
  step("loaded");

  await page.setInputFiles("#file", jobFile);
  await page.waitForFunction(() => window.motetStats.previewStrokes > 0, null, { timeout: 20000 });
  out.preview_strokes = await page.evaluate(() => window.motetStats.previewStrokes);
  out.job_info = await page.textContent("#job-info");
  await page.waitForSelector("#start:not([disabled])", { timeout: 10000 });
  step("previewed");

  const state = () => page.textContent("#state");
  const waitState = (s, ms = 20000) => page.waitForFunction((want) => document.body.dataset.state === want, s, { timeout: ms });
  await page.click("#start");
  await waitState("running");
  // The nodes' clocks settle for a few seconds after the server starts:
  // the job moves once they have.
  const first = await page.evaluate(() => window.motetStats.positions);
  await page.waitForFunction((n) => window.motetStats.positions > n + 1, first, { timeout: 15000 });
  const before = await page.evaluate(() => ({ ...window.motetStats, ages: [] }));
  const t1 = Date.now();
  await page.waitForTimeout(2000);
  const during = await page.evaluate(() => ({ updates: window.motetStats.updates, positions: window.motetStats.positions, ages: window.motetStats.ages.slice() }));
  const secs = (Date.now() - t1) / 1000;
  out.updates_per_s = (during.updates - before.updates) / secs;
  out.positions_moved = during.positions - before.positions;
  const ages = during.ages.slice(-Math.round(out.updates_per_s * secs)).sort((a, b) => a - b);
  out.age_ms = { p50: ages[Math.floor(ages.length / 2)], p95: ages[Math.floor(ages.length * 0.95)], max: ages[ages.length - 1] };
  step("running");

  // A run that left "running" by itself says why on the page: show it.
  if ((await page.evaluate(() => document.body.dataset.state)) !== "running") {
    const said = await page.evaluate(() => ({
      state: document.body.dataset.state,
      error: document.getElementById("error").textContent,
      events: document.getElementById("events").textContent.slice(-2000),
    }));
    throw new Error("the run left running before the pause: " + JSON.stringify(said));
  }
  await page.click("#pause");
  await waitState("paused");
  const held = await page.textContent("#position");
  await page.waitForTimeout(400);
  out.still_when_paused = held === (await page.textContent("#position"));
  step("paused");

  await page.click("#resume");
  await waitState("running");
  await page.waitForTimeout(1500);
  await page.screenshot({ path: shots + "/serve.png" });
  step("resumed");

  const clicked = Date.now();
  await page.click("#estop");
  await waitState("stopped");
  out.click_to_rest_ms = Date.now() - clicked;
  // The click on the trajectory's clock (the pushes carry both clocks),
  // against when the nodes began braking there (the server's stop event:
  // its request time plus the delay it reports).
  const clickUs = await page.evaluate(() => {
    const clickedWall = window.motetStats.estopPressedWall;
    const sp = window.motetStats.speeds;
    const last = sp[sp.length - 1];
    const offset = last[2] - last[0] / 1000; // wall ms minus server ms
    return (clickedWall - offset) * 1000;
  });
  const stopEvents = await page.evaluate(async () => {
    const r = await fetch("/api/events", { headers: { "X-Motet-Client": "test" } });
    return await r.json();
  });
  const stopEvent = stopEvents
    .map((e) => [e, /emergency stop: braking (-?\d+(?:\.\d+)?) ms/.exec(e.message)])
    .find(([, m]) => m);
  out.click_to_braking_ms = stopEvent ? (stopEvent[0].t_us + Number(stopEvent[1][1]) * 1000 - clickUs) / 1000 : null;
  // As the page saw it: the first pushed speed below the speed at the
  // click (pushes are 20 ms apart and speed is taken over 10 ms, so this
  // is later than the braking itself).
  out.click_to_slowing_seen_ms = await page.evaluate((clickUs) => {
    const sp = window.motetStats.speeds;
    const atClick = sp.filter((p) => p[0] <= clickUs).pop();
    const v0 = atClick ? atClick[1] : 0;
    const slowing = sp.find((p) => p[0] > clickUs && p[1] < v0 * 0.99);
    return slowing ? (slowing[0] - clickUs) / 1000 : null;
  }, clickUs);
  out.final_state = await state();
  // Simulated nodes have no link: the page offers no pairing.
  out.pair_hidden = await page.$eval("#pair", (el) => el.hidden);
  // At rest on the job's path: the distance from the rest point to the
  // nearest segment of the preview.
  out.off_path = await page.evaluate(async () => {
    const h = { "X-Motet-Client": "test" };
    const st = await (await fetch("/api/status", { headers: h })).json();
    const pv = await (await fetch("/api/jobs/" + window.motetStats.jobId + "/preview", { headers: h })).json();
    const [px, py] = st.position;
    let best = Infinity;
    for (const s of pv.strokes) {
      for (let i = 1; i < s.points.length; i++) {
        const [ax, ay] = s.points[i - 1], [bx, by] = s.points[i];
        const dx = bx - ax, dy = by - ay, l2 = dx * dx + dy * dy;
        const t = l2 > 0 ? Math.max(0, Math.min(1, ((px - ax) * dx + (py - ay) * dy) / l2)) : 0;
        best = Math.min(best, Math.hypot(px - ax - t * dx, py - ay - t * dy));
      }
    }
    return best;
  });
  const events = await page.$$eval("#events li", (lis) => lis.map((l) => l.textContent));
  out.stop_event = events.some((e) => e.includes("every node at rest on the path"));
  // The server's own figure: when the tail took over after the request.
  const braking = events.map((e) => /emergency stop: braking (-?\d+(?:\.\d+)?) ms/.exec(e)).find((m) => m);
  out.request_to_braking_ms = braking ? Number(braking[1]) : null;
  step("stopped");

  await page.setViewportSize({ width: 390, height: 844 });
  await page.waitForTimeout(200);
  const box = await page.locator("#estop").boundingBox();
  out.phone_estop_visible = !!box && box.y >= 0 && box.y + box.height <= 844 && box.x >= 0 && box.x + box.width <= 390;
  const wide = await page.evaluate(() => document.documentElement.scrollWidth);
  out.phone_no_sideways_scroll = wide <= 390;
  await page.screenshot({ path: shots + "/serve-phone.png" });
  step("phone");
  out.page_errors = errors;
} finally {
  await browser.close();
}
console.log(JSON.stringify(out));
