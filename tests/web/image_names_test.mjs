// The viewer's copy of the clean-name rule for photos (web/src/image_names.js) against the
// cases the server's rule is checked against (tests/api/image_names_cases.json,
// tests/api/image_names_test.cc): a photo sent from the browser must get the name the server
// would give it. Plain node, no packages.
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

import { cleanImageName } from '../../web/src/image_names.js';

const here = dirname(fileURLToPath(import.meta.url));
const cases = JSON.parse(readFileSync(join(here, '../api/image_names_cases.json'), 'utf8'));
assert.ok(cases.length >= 10, 'too few cases');
let failed = 0;
for (const c of cases) {
  const got = cleanImageName(c.name);
  if (got !== c.clean) {
    failed += 1;
    console.error(`${JSON.stringify(c.name)} (${c.why}): got ${JSON.stringify(got)}, want ${JSON.stringify(c.clean)}`);
  }
}
assert.equal(failed, 0, `${failed} of ${cases.length} names cleaned unlike the server`);
console.log(`${cases.length} names cleaned as the server cleans them`);
