// What the test pages share (served by sand_editor.bench.browser.run_page at /page.mjs):
// everything the console says as an error or a warning is kept in ``logged``, and ``run``
// reads /params.json, runs the page's work and posts any failure to /error.
export const logged = [];
const listeners = [];

for (const level of ['error', 'warn']) {
    const original = console[level].bind(console);
    console[level] = (...args) => {
        const text = args.map(String).join(' ');
        logged.push(`${level}: ${text}`);
        original(...args);
        if (level === 'error') for (const listener of listeners) listener(new Error(text));
    };
}
window.addEventListener('error', (event) => logged.push(`error: ${event.message}`));

export async function post(path, body) {
    await fetch(path, { method: 'POST', body });
}

// A promise that rejects at the first console error from now on (one in an XR frame, say,
// which the browser reports rather than throws).
export function consoleFailure() {
    return new Promise((_, reject) => listeners.push(reject));
}

// A canvas of width × height pixels on the page.
export function canvasOf(width, height) {
    const canvas = document.createElement('canvas');
    canvas.width = width;
    canvas.height = height;
    document.body.append(canvas);
    return canvas;
}

export async function run(work) {
    try {
        const params = await (await fetch('/params.json')).json();
        await work(params);
    } catch (error) {
        await post('/error', String(error && error.stack ? error.stack : error));
    }
}
