// tests/coordinator/dashboard/test_dashboard.sh's browser: Debian's chromium, headless, driven by playwright-core.
//
//   node drive.js BASE_URL KEY_FILE CHROMIUM [SCREENSHOT_DIR]
//
// Opens the dashboard of a coordinator that runs one job on one worker and checks what a
// person would: the job listed, its progress rising, its preview changing between two
// screenshots, the plots drawn with numbers on both axes, the worker listed with its tags;
// an action without a session refused; a wrong key refused, the refusal still shown after
// the page's next poll; with the right key, the job paused, resumed, given another
// priority and cancelled through the page, each shown in the Events panel's job list;
// Remove asking first: declined, the job stays; accepted, it goes. With SCREENSHOT_DIR, writes dashboard.png (the page)
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
  for (const id of ['plot-time', 'plot-iterations'])
    for (const axis of ['x', 'y']) {
      const labels = await page.locator(`#${id} text.tick-${axis}`).allTextContents();
      const numbers = labels.map(Number);
      check(`the ${id} plot's ${axis} axis is numbered`, labels.length >= 2 && numbers.every(Number.isFinite) &&
        numbers.every((v, i) => i === 0 || (axis === 'x' ? v > numbers[i - 1] : v !== numbers[i - 1])), labels.join(' '));
    }
  const workerTags = await page.textContent('#worker-rows td.tags');
  check("the worker's tags are listed", workerTags.includes('night'), workerTags);
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
  const rowSays = (text) => page.waitForFunction((t) => {
    const row = document.querySelector('tr.job[data-job="1"]');
    return row && row.querySelector('td:nth-child(3)').textContent === t;
  }, text, { timeout: 15000 });
  const eventShown = async (kind) => {
    await page.waitForSelector(`#job-event-list li[data-kind="${kind}"]`, { timeout: 15000 });
    return page.textContent(`#job-event-list li[data-kind="${kind}"]`);
  };
  check('the Events panel shows the job submitted', (await eventShown('job_submitted')).includes('job 1'));
  await page.click('#pause');
  await rowSays('paused');
  check('the job is paused through the page', true, await page.textContent('#action-result'));
  check('the Events panel shows the pause', (await eventShown('job_paused')).includes('no new leases'));
  const frozen = await page.textContent('tr.job[data-job="1"]');
  await page.click('#resume');
  await rowSays('running');
  check('the job is resumed through the page', true, await page.textContent('#action-result'));
  check('the Events panel shows the resume', (await eventShown('job_resumed')).includes('resumed job 1'), frozen.trim());
  await page.fill('#priority', '3');
  await page.click('#set-priority');
  check('the Events panel shows the priority changed', (await eventShown('priority_changed')).includes('priority 1 -> 3'));
  await page.click('#cancel');
  await rowSays('cancelled');
  check('the job is cancelled through the page', true, await page.textContent('#action-result'));
  check('the Events panel shows the cancel', (await eventShown('job_cancelled')).includes('cancelled'));
  check('worker events stay in their own list',
    (await page.locator('#job-event-list li[data-kind="worker_registered"]').count()) === 0 &&
    (await page.locator('#event-list li[data-kind="worker_registered"]').count()) > 0);

  // Remove asks first: declined, nothing is sent and the job stays.
  let asked = '';
  page.once('dialog', (d) => { asked = d.message(); d.dismiss(); });
  await page.click('#remove');
  check('Remove asks before it deletes', asked.includes('Remove job 1') && asked.includes('cannot be undone'), asked);
  await sleep(2500); // past the page's next poll
  check('declining keeps the job', (await page.locator('tr.job[data-job="1"]').count()) === 1,
    await page.textContent('#action-result'));
  page.once('dialog', (d) => d.accept());
  await page.click('#remove');
  await page.waitForFunction(() => !document.querySelector('tr.job[data-job="1"]'), null, { timeout: 15000 });
  check('accepting removes the job', true, await page.textContent('#action-result'));
  await browser.close();
  process.exit(failed ? 1 : 0);
})().catch((e) => {
  console.log('FAIL ' + e.message);
  process.exit(1);
});
