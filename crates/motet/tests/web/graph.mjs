// Drives a hand-driven machine's page (`motet serve MACHINE --graph GRAPH`)
// in Debian's chromium: the graph's inputs and its components' live
// parameters are sliders; moving a parameter's, then two inputs', moves
// the machine. Prints one JSON line of what it saw (the Rust test checks
// the machine's position against the same graph run offline).
// Usage: node graph.mjs URL PARAMS_JSON INPUTS_JSON SCREENSHOT
// (PARAMS_JSON: [["component", "param", value], ...])
import { launch } from "./browser.mjs";

const [url, paramsJson, inputsJson, shot] = process.argv.slice(2);
const params = JSON.parse(paramsJson);
const inputs = JSON.parse(inputsJson);
const out = {};

const browser = await launch();
try {
  const page = await browser.newPage({ viewport: { width: 1280, height: 900 } });
  const errors = [];
  page.on("pageerror", (e) => errors.push(String(e)));
  await page.goto(url);
  await page.waitForSelector("body[data-ready='1']", { timeout: 10000 });
  out.sliders = await page.$$eval("#graph-inputs input", (els) => els.map((e) => e.id + ":" + e.type));
  out.param_sliders = await page.$$eval("#graph-params input", (els) => els.length);
  for (const [comp, name, value] of params) {
    await page.$eval("#param-" + comp + "-" + name, (el, v) => {
      el.value = String(v);
      el.dispatchEvent(new Event("input", { bubbles: true }));
    }, value);
  }
  // The parameters are set before the inputs move, as the Rust test's
  // offline run has them.
  let g = null;
  for (let tries = 0; tries < 250; tries++) {
    g = await page.evaluate(async () => (await fetch("/api/graph")).json());
    if (g.param_changes >= params.length) break;
    await page.waitForTimeout(20);
  }
  g = g.components;
  out.params = Object.fromEntries(params.map(([comp, name]) =>
    [comp + "." + name, g.find((c) => c.name === comp).params.find((p) => p.name === name).value]));
  for (const [name, value] of Object.entries(inputs)) {
    // As a person dragging the slider: its value changes, then `input`.
    await page.$eval("#graph-" + name, (el, v) => {
      el.value = String(v);
      el.dispatchEvent(new Event("input", { bubbles: true }));
    }, value);
  }
  // What the server took, once the page's sends have gone out.
  await page.waitForTimeout(300);
  const took = await page.evaluate(async () => (await (await fetch("/api/graph")).json()).inputs);
  out.inputs = Object.fromEntries(took.map((i) => [i.name, i.value]));
  await page.waitForTimeout(1200);
  out.position = await page.evaluate(async () => (await (await fetch("/api/graph")).json()).position);
  await page.screenshot({ path: shot });
  out.page_errors = errors;
} finally {
  await browser.close();
}
console.log(JSON.stringify(out));
