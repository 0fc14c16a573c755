// Validates one glTF or GLB file with the Khronos glTF validator and prints its JSON report.
//   SAND_EDITOR_JS=<folder with node_modules> node tools/js/validate.mjs <file.gltf|file.glb>
// External resources (buffers, images) are read from the file's folder. The exit status is 0
// whenever a report was produced, whatever it contains; 2 for bad arguments, 1 when the
// validator could not run (unreadable file, undetectable format).
import { readFile } from 'node:fs/promises';
import { createRequire } from 'node:module';
import path from 'node:path';

const root = process.env.SAND_EDITOR_JS;
const file = process.argv[2];
if (!root || !file || process.argv.length !== 3) {
    console.error('usage: SAND_EDITOR_JS=<folder with node_modules> node validate.mjs <file>');
    process.exit(2);
}

const validator = createRequire(path.join(path.resolve(root), 'package.json'))('gltf-validator');
const fullPath = path.resolve(file);

try {
    const data = new Uint8Array(await readFile(fullPath));
    const report = await validator.validateBytes(data, {
        uri: path.basename(fullPath),
        maxIssues: 0,
        writeTimestamp: false,
        externalResourceFunction: async (uri) =>
            new Uint8Array(await readFile(path.resolve(path.dirname(fullPath), decodeURIComponent(uri)))),
    });
    process.stdout.write(JSON.stringify(report, null, 2) + '\n');
} catch (error) {
    console.error(`glTF validator failed on ${fullPath}: ${error}`);
    process.exit(1);
}
