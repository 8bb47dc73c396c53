// The interop tests' rule for missing tools (tests/README.md): exit 77
// (ctest SKIP_RETURN_CODE) unless PRT_REQUIRE_TOOLS=1, then fail (exit 1).
'use strict';
function missing(what) {
  if (process.env.PRT_REQUIRE_TOOLS === '1') {
    console.error(`FAIL: ${what} is missing and PRT_REQUIRE_TOOLS=1`);
    process.exit(1);
  }
  console.error(`SKIP: ${what} is missing (npm ci --prefix tests/js; scripts/install-deps.sh)`);
  process.exit(77);
}
// playwright-core's chromium and the Chromium it drives (PRT_CHROMIUM, else
// Debian's /usr/bin/chromium), or missing() for either.
function chromiumOrSkip() {
  let chromium;
  try {
    ({ chromium } = require('playwright-core'));
  } catch (e) {
    missing('the npm package playwright-core');
  }
  const executable = process.env.PRT_CHROMIUM || '/usr/bin/chromium';
  if (!require('fs').existsSync(executable)) missing('Chromium (' + executable + ')');
  return { chromium, executable };
}

// The test's --name value pairs; usage and exit 2 without --prt and --source.
function testArgs(script) {
  const args = {};
  for (let i = 2; i < process.argv.length; i += 2) args[process.argv[i].replace(/^--/, '')] = process.argv[i + 1];
  if (!args.prt || !args.source) {
    console.error(`usage: node ${script} --prt BUILD/prt --source SRC [--images DIR]`);
    process.exit(2);
  }
  return args;
}

module.exports = { missing, chromiumOrSkip, testArgs };
