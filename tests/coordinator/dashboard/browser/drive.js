// tests/coordinator/dashboard/test_dashboard.sh's browser: Debian's chromium, headless, driven by playwright-core.
//
//   node drive.js BASE_URL KEY_FILE CHROMIUM [SCREENSHOT_DIR]
//
// Opens the dashboard of a coordinator that runs one job on one worker and checks what a
// person would: the job listed, its progress rising, its preview changing between two
// screenshots, the plot drawn, the worker listed; an action without a session refused; a
// wrong key refused, the refusal still shown after the page's next poll; the job cancelled
// with the right key through the page. With SCREENSHOT_DIR, writes dashboard.png (the page)
// and dashboard-job.png (the job).
'use strict';
const fs = require('fs');
const { chromium } = require('playwright-core');

const [base, keyFile, executable, shots] = process.argv.slice(2);
const key = fs.readFileSync(keyFile, 'utf8').trim();
let failed = false;
function check(what, ok, detail) {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}${detail ? ': ' + detail : ''}`);
  if (!ok) failed = true;
  return ok;
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

(async () => {
  const browser = await chromium.launch({ executablePath: executable, args: ['--no-sandbox'] });
  const page = await browser.newPage({ viewport: { width: 1360, height: 1000 } });
  page.on('pageerror', (e) => check('no script error', false, e.message));
  await page.goto(base + '/');
  await page.waitForSelector('tr.job[data-job="1"]', { timeout: 20000 });
  check('the job is listed', (await page.textContent('tr.job[data-job="1"]')).includes('cornell'));
  await page.waitForSelector('#worker-rows tr.worker', { timeout: 20000 });
  const worker = await page.textContent('#worker-rows');
  check('the worker is listed', worker.includes('w1'), worker.trim().slice(0, 80));

  const progress = async () => parseFloat(await page.getAttribute('tr.job[data-job="1"] .bar', 'title'));
  const previewBytes = async () => {
    await page.waitForFunction(() => {
      const img = document.getElementById('preview');
      return img.src.startsWith('blob:') && img.complete && img.naturalWidth > 0;
    }, null, { timeout: 20000 });
    return page.locator('#preview').screenshot();
  };
  const p0 = await progress();
  const shot0 = await previewBytes();
  let p1 = p0, shot1 = shot0;
  for (let i = 0; i < 30 && (p1 <= p0 || shot1.equals(shot0)); i++) {
    await sleep(1000);
    p1 = await progress();
    shot1 = await previewBytes();
  }
  check('the progress rises', p1 > p0, `${p0}% then ${p1}%`);
  check('the preview changes between two screenshots', !shot1.equals(shot0), `${shot0.length} and ${shot1.length} bytes`);
  await page.waitForSelector('#plot-time path.line', { timeout: 20000 });
  const d = await page.getAttribute('#plot-time path.line', 'd');
  check('the error-against-time plot is drawn', /^M[\d. ]+(L[\d. ]+)*$/.test(d) && d.length > 4, d.slice(0, 40));
  check('the error-against-iterations plot is drawn', (await page.locator('#plot-iterations path.line').count()) > 0);
  const facts = await page.textContent('#job-facts');
  check("the job's settings are shown", /settings\s*algorithm=\S+ max_path_length=\d+ radius_factor=/.test(facts), facts.trim());
  const ranges = await page.textContent('#job-ranges');
  check('the worker rendering the job is named with its range', /w1\s*\[\d+, \d+\)/.test(ranges), ranges.trim());

  if (shots) {
    await sleep(3500); // one more checkpoint and plot point for the picture
    await page.screenshot({ path: `${shots}/dashboard.png`, fullPage: true });
    await page.locator('#job').screenshot({ path: `${shots}/dashboard-job.png` });
  }

  const unsigned = await page.evaluate(async () => (await fetch('/api/jobs/1/cancel', { method: 'POST' })).status);
  check('a cancel without a session token is refused', unsigned === 401, `HTTP ${unsigned}`);
  const viaGet = await page.evaluate(async () => (await fetch('/api/jobs/1/cancel')).status);
  check('a cancel through GET is refused', viaGet === 405, `HTTP ${viaGet}`);

  await page.fill('#key', '0'.repeat(64));
  await page.click('#sign-in-button');
  await page.waitForSelector('#notice:not([hidden])', { timeout: 10000 });
  const refused = await page.textContent('#notice');
  check('a wrong key does not sign in', refused.includes('Not signed in') && await page.isHidden('#signed-in'), refused);
  check('the key field is emptied', (await page.inputValue('#key')) === '');
  await sleep(2500); // longer than the page's poll (2 s), whose answers must not clear it
  check('the refusal stays after the next poll', (await page.isVisible('#notice')) &&
    (await page.textContent('#notice')) === refused, await page.textContent('#notice'));

  await page.fill('#key', key);
  await page.click('#sign-in-button');
  await page.waitForSelector('#signed-in:not([hidden])', { timeout: 10000 });
  check('the farm key signs in', true);
  const stored = await page.evaluate(() => JSON.stringify(localStorage) + JSON.stringify(sessionStorage) + document.cookie);
  check('the key is stored nowhere', !stored.includes(key));
  await page.click('#cancel');
  await page.waitForFunction(() => {
    const row = document.querySelector('tr.job[data-job="1"]');
    return row && row.textContent.includes('cancelled');
  }, null, { timeout: 15000 });
  check('the job is cancelled through the page', true, await page.textContent('#action-result'));
  await browser.close();
  process.exit(failed ? 1 : 0);
})().catch((e) => {
  console.log('FAIL ' + e.message);
  process.exit(1);
});
