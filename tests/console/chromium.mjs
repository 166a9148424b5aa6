// Debian's Chromium, headless, as the console's browser checks launch it (software WebGL; no background
// connections this machine's closed network would refuse).
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';

const here = path.dirname(fileURLToPath(import.meta.url));
const require = createRequire(path.resolve(here, '../../client/console/web/package.json'));
const { chromium } = require('playwright-core');

// `signals` false leaves SIGTERM and SIGINT to the caller (Playwright would close the browser on them).
export function launchChromium(executablePath, signals = true) {
  return chromium.launch({
    executablePath,
    headless: true,
    handleSIGTERM: signals,
    handleSIGINT: signals,
    args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking',
      '--disable-component-update', '--disable-sync', '--use-gl=angle', '--use-angle=swiftshader',
      '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'],
  });
}
