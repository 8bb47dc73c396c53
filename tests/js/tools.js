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
module.exports = { missing };
