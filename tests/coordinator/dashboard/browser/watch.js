// tests/bench/dashboard_cpu.sh's browser: keeps the dashboard open, polling as a person's
// tab would, for SECONDS.   node watch.js BASE_URL CHROMIUM SECONDS
'use strict';
const { chromium } = require('playwright-core');
const [base, executable, seconds] = process.argv.slice(2);
(async () => {
  const browser = await chromium.launch({ executablePath: executable, args: ['--no-sandbox'] });
  const page = await browser.newPage({ viewport: { width: 1360, height: 1000 } });
  await page.goto(base + '/');
  await page.waitForSelector('tr.job', { timeout: 20000 });
  await new Promise((r) => setTimeout(r, Number(seconds) * 1000));
  await browser.close();
})().catch((e) => { console.error(e.message); process.exit(1); });
