#!/usr/bin/env node
// Keeps the vog-console page open in headless Chromium until SIGTERM (or --seconds), then writes what it
// measured as JSON: the latency from vogd publishing a pose to the page drawing it, frame times, and,
// with --screenshot, a picture of the page. vog-bench console and scripts/demo run it.
//   node tests/console/measure_page.mjs --url http://127.0.0.1:PORT/ --json out.json [--screenshot out.png]
//        [--seconds S] [--chromium /usr/bin/chromium]
import fs from 'node:fs';
import { launchChromium } from './chromium.mjs';

const opt = { chromium: '/usr/bin/chromium', seconds: 0 };
for (let i = 2; i < process.argv.length; i += 2) opt[process.argv[i].replace(/^--/, '')] = process.argv[i + 1];
if (!opt.url || !opt.json) {
  console.error('usage: measure_page.mjs --url URL --json FILE [--screenshot FILE] [--seconds S]');
  process.exit(2);
}

function percentile(values, p) {
  if (values.length === 0) return null;
  const v = [...values].sort((a, b) => a - b);
  const at = p * (v.length - 1);
  const lo = Math.floor(at);
  return v[lo] + (v[Math.min(lo + 1, v.length - 1)] - v[lo]) * (at - lo);
}

const browser = await launchChromium(opt.chromium, false);
const page = await browser.newPage({ viewport: { width: 1440, height: 860 } });
const errors = [];
page.on('pageerror', (e) => errors.push(String(e)));
await page.goto(opt.url);
await page.waitForFunction(() => window.vogConsole && window.vogConsole.linkState() === 'connected', null,
  { timeout: 30000 });

let stopping = false;
const stop = new Promise((resolve) => {
  process.on('SIGTERM', resolve);
  process.on('SIGINT', resolve);
  if (Number(opt.seconds) > 0) setTimeout(resolve, Number(opt.seconds) * 1000);
});
await stop;
if (!stopping) {
  stopping = true;
  // Let the last messages be drawn.
  await page.waitForFunction(() => window.vogConsole.pendingMessages() === 0, null, { timeout: 20000 }).catch(() => {});
  await page.waitForTimeout(500);
  if (opt.screenshot) await page.screenshot({ path: opt.screenshot });
  const m = await page.evaluate(() => ({
    latencies: window.vogConsole.poseLatencies(),
    frames: window.vogConsole.frameTimes(),
    maxFrameMs: window.vogConsole.maxFrameMs(),
    occupied: window.vogConsole.occupiedCount(),
  }));
  const out = {
    pose_latency_ms_p50: percentile(m.latencies, 0.5),
    pose_latency_ms_p99: percentile(m.latencies, 0.99),
    poses_drawn: m.latencies.length,
    frame_ms_p50: percentile(m.frames, 0.5),
    frame_ms_p99: percentile(m.frames, 0.99),
    frame_ms_max: m.maxFrameMs,
    frames: m.frames.length,
    frames_over_100ms: m.frames.filter((f) => f > 100).length,
    occupied_shown: m.occupied,
    page_errors: errors.length,
  };
  fs.writeFileSync(opt.json, JSON.stringify(out, null, 2) + '\n');
  await browser.close();
  process.exit(errors.length === 0 ? 0 : 1);
}
