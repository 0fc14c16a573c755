// Renders the model named in /params.json with three.js, lit by one directional light only (no
// environment, no ambient, lights in the file removed), and posts the frame back to the harness
// (tests/export/js_tools.py):
//   /result  the linear radiance as RGBA float32, rows bottom-up, from a float render target
//   /png     the same frame drawn to the canvas in sRGB (8-bit PNG, for people to look at)
// params.json: model (URL), width, height, view and projection (4x4, column-major arrays, the
// OpenGL conventions), sunDirection (towards the light, world), sunIrradiance (linear RGB, W/m²).
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

async function post(path, body) {
    const response = await fetch(path, { method: 'POST', body });
    if (!response.ok) throw new Error(`POST ${path} answered ${response.status}`);
}

function sunLight(direction, irradiance) {
    // A directional light of colour c and intensity I gives irradiance c·I on a surface facing it.
    const peak = Math.max(...irradiance);
    const color = peak > 0
        ? new THREE.Color(irradiance[0] / peak, irradiance[1] / peak, irradiance[2] / peak)
        : new THREE.Color(0, 0, 0);
    const light = new THREE.DirectionalLight(color, peak);
    light.position.fromArray(direction);
    light.target.position.set(0, 0, 0);
    return light;
}

function fixedCamera(view, projection) {
    const camera = new THREE.PerspectiveCamera();
    camera.matrixAutoUpdate = false;
    camera.matrixWorldAutoUpdate = false;
    camera.matrixWorldInverse.fromArray(view);
    camera.matrixWorld.copy(camera.matrixWorldInverse).invert();
    camera.matrix.copy(camera.matrixWorld);
    camera.matrix.decompose(camera.position, camera.quaternion, camera.scale);
    camera.projectionMatrix.fromArray(projection);
    camera.projectionMatrixInverse.copy(camera.projectionMatrix).invert();
    return camera;
}

async function main() {
    const params = await (await fetch('/params.json')).json();
    const { width, height } = params;

    const renderer = new THREE.WebGLRenderer({
        antialias: false,
        preserveDrawingBuffer: true,
        alpha: false,
        powerPreference: 'high-performance',
    });
    if (!renderer.capabilities.isWebGL2) throw new Error('WebGL2 is not available');
    if (!renderer.extensions.has('EXT_color_buffer_float')) {
        throw new Error('EXT_color_buffer_float is not available: no float render targets');
    }
    renderer.setPixelRatio(1);
    renderer.setSize(width, height, false);
    renderer.toneMapping = THREE.NoToneMapping;
    renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
    renderer.setClearColor(0x000000, 0);
    document.body.appendChild(renderer.domElement);

    const gltf = await new GLTFLoader().loadAsync(params.model);
    const model = gltf.scene;
    const fileLights = [];
    model.traverse((object) => { if (object.isLight) fileLights.push(object); });
    for (const light of fileLights) light.removeFromParent();

    const scene = new THREE.Scene();
    scene.background = null;
    scene.environment = null;
    scene.add(model);
    const sun = sunLight(params.sunDirection, params.sunIrradiance);
    scene.add(sun, sun.target);
    const camera = fixedCamera(params.view, params.projection);

    const target = new THREE.WebGLRenderTarget(width, height, {
        type: THREE.FloatType,
        format: THREE.RGBAFormat,
        colorSpace: THREE.LinearSRGBColorSpace,
        minFilter: THREE.NearestFilter,
        magFilter: THREE.NearestFilter,
        generateMipmaps: false,
        depthBuffer: true,
    });
    renderer.setRenderTarget(target);
    renderer.clear();
    renderer.render(scene, camera);
    const pixels = new Float32Array(width * height * 4);
    renderer.readRenderTargetPixels(target, 0, 0, width, height, pixels);
    renderer.setRenderTarget(null);

    renderer.outputColorSpace = THREE.SRGBColorSpace;
    renderer.setClearColor(0x000000, 1);
    renderer.clear();
    renderer.render(scene, camera);
    const png = await new Promise((resolve, reject) => renderer.domElement.toBlob(
        (blob) => (blob ? resolve(blob) : reject(new Error('canvas.toBlob gave nothing'))),
        'image/png',
    ));

    const gl = renderer.getContext();
    const debug = gl.getExtension('WEBGL_debug_renderer_info');
    await post('/info', JSON.stringify({
        revision: THREE.REVISION,
        glVersion: gl.getParameter(gl.VERSION),
        glRenderer: debug ? gl.getParameter(debug.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER),
        fileLightsRemoved: fileLights.length,
    }));
    await post('/png', png);
    await post('/result', pixels.buffer);
}

main().catch((error) => window.reportError(error && error.stack ? error.stack : String(error)));
