// Sand Editor's web viewer: draws an exported sand (scene.json and its .bin files) in WebGL2 as
// the desktop renderer does — sky, dunes in the sand material (glints, far BRDF, ripples and
// the blend between them), bloom, exposure and tone mapping — on a canvas and in WebXR.
//
// Every shader comes from scene.json (the renderer's GLSL as GLSL ES 3.00) and every uniform
// value from the exporter; this file only moves data to the GPU and draws.

const FLOAT_LINEAR = 'OES_texture_float_linear';
const SHADOW_UNIT = 15;  // the surface's shadow map sampler: no map bound (no shadows drawn)

// ---- column-major 4x4 matrices (Float64Array(16)) ------------------------------------------

export const mat4 = {
    identity() {
        const m = new Float64Array(16);
        m[0] = m[5] = m[10] = m[15] = 1;
        return m;
    },
    multiply(a, b) {
        const out = new Float64Array(16);
        for (let c = 0; c < 4; ++c) {
            for (let r = 0; r < 4; ++r) {
                let sum = 0;
                for (let k = 0; k < 4; ++k) sum += a[k * 4 + r] * b[c * 4 + k];
                out[c * 4 + r] = sum;
            }
        }
        return out;
    },
    translation(x, y, z) {
        const m = mat4.identity();
        m[12] = x; m[13] = y; m[14] = z;
        return m;
    },
    invert(m) {
        // Cofactors over the determinant (after gl-matrix's mat4.invert).
        const [a00, a01, a02, a03, a10, a11, a12, a13, a20, a21, a22, a23, a30, a31, a32, a33] = m;
        const b00 = a00 * a11 - a01 * a10, b01 = a00 * a12 - a02 * a10;
        const b02 = a00 * a13 - a03 * a10, b03 = a01 * a12 - a02 * a11;
        const b04 = a01 * a13 - a03 * a11, b05 = a02 * a13 - a03 * a12;
        const b06 = a20 * a31 - a21 * a30, b07 = a20 * a32 - a22 * a30;
        const b08 = a20 * a33 - a23 * a30, b09 = a21 * a32 - a22 * a31;
        const b10 = a21 * a33 - a23 * a31, b11 = a22 * a33 - a23 * a32;
        const det = b00 * b11 - b01 * b10 + b02 * b09 + b03 * b08 - b04 * b07 + b05 * b06;
        if (!det) throw new Error('singular matrix');
        const d = 1 / det;
        return Float64Array.from([
            (a11 * b11 - a12 * b10 + a13 * b09) * d, (a02 * b10 - a01 * b11 - a03 * b09) * d,
            (a31 * b05 - a32 * b04 + a33 * b03) * d, (a22 * b04 - a21 * b05 - a23 * b03) * d,
            (a12 * b08 - a10 * b11 - a13 * b07) * d, (a00 * b11 - a02 * b08 + a03 * b07) * d,
            (a32 * b02 - a30 * b05 - a33 * b01) * d, (a20 * b05 - a22 * b02 + a23 * b01) * d,
            (a10 * b10 - a11 * b08 + a13 * b06) * d, (a01 * b08 - a00 * b10 - a03 * b06) * d,
            (a30 * b04 - a31 * b02 + a33 * b00) * d, (a21 * b02 - a20 * b04 - a23 * b00) * d,
            (a11 * b07 - a10 * b09 - a12 * b06) * d, (a00 * b09 - a01 * b07 + a02 * b06) * d,
            (a31 * b01 - a30 * b03 - a32 * b00) * d, (a20 * b03 - a21 * b01 + a22 * b00) * d,
        ]);
    },
    lookAt(eye, target, up) {
        let f = sub(target, eye);
        f = scale(f, 1 / Math.hypot(...f));
        let s = cross(f, up);
        s = scale(s, 1 / Math.hypot(...s));
        const u = cross(s, f);
        return Float64Array.from([
            s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0,
            -dot(s, eye), -dot(u, eye), dot(f, eye), 1,
        ]);
    },
    perspective(fovYDeg, aspect, near, far) {
        const f = 1 / Math.tan((fovYDeg * Math.PI) / 360);
        const m = new Float64Array(16);
        m[0] = f / aspect;
        m[5] = f;
        m[10] = (far + near) / (near - far);
        m[11] = -1;
        m[14] = (2 * far * near) / (near - far);
        return m;
    },
};

function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
function scale(a, s) { return [a[0] * s, a[1] * s, a[2] * s]; }
function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
function cross(a, b) {
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
}

// ---- half floats, where 32-bit float textures cannot be filtered ------------------------------

const f32 = new Float32Array(1);
const u32 = new Uint32Array(f32.buffer);

function toHalf(value) {
    f32[0] = value;
    const x = u32[0];
    const sign = (x >>> 16) & 0x8000;
    const exponent = ((x >>> 23) & 0xff) - 127 + 15;
    const mantissa = x & 0x7fffff;
    if (((x >>> 23) & 0xff) === 0xff) return sign | 0x7c00 | (mantissa ? 0x200 : 0);
    if (exponent >= 31) return sign | 0x7bff;  // the largest half: never an inf
    if (exponent <= 0) {
        if (exponent < -10) return sign;
        const m = mantissa | 0x800000;
        return sign | Math.round(m / 2 ** (14 - exponent));
    }
    return sign | (exponent << 10) | Math.round(mantissa / 0x2000);
}

const HALF_OF = { R32F: 'R16F', RG32F: 'RG16F', RGBA32F: 'RGBA16F' };

// ---- programs and uniforms --------------------------------------------------------------------

class Program {
    constructor(gl, name, source) {
        this.gl = gl;
        this.name = name;
        const handle = gl.createProgram();
        for (const [kind, text] of [[gl.VERTEX_SHADER, source.vertex],
                                    [gl.FRAGMENT_SHADER, source.fragment]]) {
            const shader = gl.createShader(kind);
            gl.shaderSource(shader, text);
            gl.compileShader(shader);
            if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) {
                const stage = kind === gl.VERTEX_SHADER ? 'vertex' : 'fragment';
                throw new Error(`${name} (${stage}): ${gl.getShaderInfoLog(shader)}`);
            }
            gl.attachShader(handle, shader);
            gl.deleteShader(shader);
        }
        gl.linkProgram(handle);
        if (!gl.getProgramParameter(handle, gl.LINK_STATUS)) {
            throw new Error(`${name}: ${gl.getProgramInfoLog(handle)}`);
        }
        this.handle = handle;
        this.uniforms = new Map();
        const count = gl.getProgramParameter(handle, gl.ACTIVE_UNIFORMS);
        for (let i = 0; i < count; ++i) {
            const info = gl.getActiveUniform(handle, i);
            const base = info.name.replace(/\[0\]$/, '');
            this.uniforms.set(base, {
                location: gl.getUniformLocation(handle, info.name),
                type: info.type,
                size: info.size,
            });
        }
    }

    // Sets a uniform the program uses by its GL type; one it does not use is skipped, as the
    // renderer's set_uniform does.
    set(name, value) {
        const uniform = this.uniforms.get(name);
        if (!uniform) return;
        const gl = this.gl;
        const v = Array.isArray(value) || ArrayBuffer.isView(value) ? value : [value];
        const floats = () => Float32Array.from(v, Number);
        const ints = () => Int32Array.from(v, (x) => (x === true ? 1 : x === false ? 0 : x));
        const at = uniform.location;
        switch (uniform.type) {
            case gl.FLOAT: gl.uniform1fv(at, floats()); break;
            case gl.FLOAT_VEC2: gl.uniform2fv(at, floats()); break;
            case gl.FLOAT_VEC3: gl.uniform3fv(at, floats()); break;
            case gl.FLOAT_VEC4: gl.uniform4fv(at, floats()); break;
            case gl.INT_VEC2: gl.uniform2iv(at, ints()); break;
            case gl.INT_VEC3: gl.uniform3iv(at, ints()); break;
            case gl.INT_VEC4: gl.uniform4iv(at, ints()); break;
            case gl.UNSIGNED_INT: gl.uniform1uiv(at, Uint32Array.from(v, Number)); break;
            case gl.FLOAT_MAT4: gl.uniformMatrix4fv(at, false, floats()); break;
            default: gl.uniform1iv(at, ints());  // int, bool and every sampler
        }
    }

    setAll(values) {
        for (const [name, value] of Object.entries(values)) this.set(name, value);
    }

    samplers() {
        const gl = this.gl;
        const kinds = [gl.SAMPLER_2D, gl.SAMPLER_3D, gl.SAMPLER_2D_SHADOW, gl.UNSIGNED_INT_SAMPLER_2D,
                       gl.INT_SAMPLER_2D, gl.SAMPLER_2D_ARRAY, gl.SAMPLER_2D_ARRAY_SHADOW];
        return [...this.uniforms].filter(([, u]) => kinds.includes(u.type)).map(([n]) => n);
    }
}

// ---- textures ---------------------------------------------------------------------------------

function uploadTexture(gl, entry, buffer, floatLinear) {
    const target = gl[entry.target];
    const filtered = entry.min_filter !== 'NEAREST' || entry.mag_filter !== 'NEAREST';
    let internal = entry.internal_format;
    let type = entry.type;
    const halve = entry.array === 'Float32Array' && filtered && !floatLinear;
    if (halve) {
        internal = HALF_OF[internal];
        type = 'HALF_FLOAT';
    }
    const texture = gl.createTexture();
    gl.bindTexture(target, texture);
    const [w, h, d] = entry.levels[0].size;
    if (target === gl.TEXTURE_3D) {
        gl.texStorage3D(target, entry.levels.length, gl[internal], w, h, d);
    } else {
        gl.texStorage2D(target, entry.levels.length, gl[internal], w, h);
    }
    const Kind = { Float32Array, Uint16Array, Uint32Array }[entry.array];
    entry.levels.forEach((level, index) => {
        let data = new Kind(buffer, level.offset, level.bytes / Kind.BYTES_PER_ELEMENT);
        if (halve) data = Uint16Array.from(data, toHalf);
        const [lw, lh, ld] = level.size;
        if (target === gl.TEXTURE_3D) {
            gl.texSubImage3D(target, index, 0, 0, 0, lw, lh, ld, gl[entry.format], gl[type], data);
        } else {
            gl.texSubImage2D(target, index, 0, 0, lw, lh, gl[entry.format], gl[type], data);
        }
    });
    const wrap = entry.repeat ? gl.REPEAT : gl.CLAMP_TO_EDGE;
    gl.texParameteri(target, gl.TEXTURE_WRAP_S, wrap);
    gl.texParameteri(target, gl.TEXTURE_WRAP_T, wrap);
    if (target === gl.TEXTURE_3D) gl.texParameteri(target, gl.TEXTURE_WRAP_R, wrap);
    gl.texParameteri(target, gl.TEXTURE_MIN_FILTER, gl[entry.min_filter]);
    gl.texParameteri(target, gl.TEXTURE_MAG_FILTER, gl[entry.mag_filter]);
    return { texture, target, halved: halve };
}

function hdrTexture(gl, width, height) {
    const texture = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, texture);
    gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA16F, width, height);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    return texture;
}

function framebufferOf(gl, texture, depth = null) {
    const framebuffer = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, framebuffer);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, texture, 0);
    if (depth) {
        gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, depth);
    }
    const status = gl.checkFramebufferStatus(gl.FRAMEBUFFER);
    if (status !== gl.FRAMEBUFFER_COMPLETE) throw new Error(`framebuffer incomplete: ${status}`);
    return framebuffer;
}

// ---- the HDR target, bloom and tone mapping (the renderer's post chain) ----------------------

class PostChain {
    constructor(gl, programs, post) {
        this.gl = gl;
        this.programs = programs;
        this.post = post;
        this.size = null;
        this.emptyVao = gl.createVertexArray();
    }

    resize(width, height) {
        if (this.size && this.size[0] === width && this.size[1] === height) return;
        this.release();
        const gl = this.gl;
        this.sceneTexture = hdrTexture(gl, width, height);
        this.depth = gl.createRenderbuffer();
        gl.bindRenderbuffer(gl.RENDERBUFFER, this.depth);
        gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT24, width, height);
        this.sceneFramebuffer = framebufferOf(gl, this.sceneTexture, this.depth);
        this.levels = [];
        for (let level = 0; level < this.post.bloom_levels; ++level) {
            const size = [Math.max(1, width >> (level + 1)), Math.max(1, height >> (level + 1))];
            const texture = hdrTexture(gl, ...size);
            this.levels.push({ texture, framebuffer: framebufferOf(gl, texture), size });
        }
        this.size = [width, height];
    }

    pass(program, source, sourceSize, framebuffer, size, offset = [0, 0]) {
        const gl = this.gl;
        gl.bindFramebuffer(gl.FRAMEBUFFER, framebuffer);
        gl.viewport(offset[0], offset[1], size[0], size[1]);
        gl.useProgram(program.handle);
        gl.activeTexture(gl.TEXTURE0);
        gl.bindTexture(gl.TEXTURE_2D, source);
        program.set('u_source', 0);
        program.set('u_source_texel', [1 / sourceSize[0], 1 / sourceSize[1]]);
        program.set('u_viewport', [offset[0], offset[1], size[0], size[1]]);
        gl.bindVertexArray(this.emptyVao);
        gl.drawArrays(gl.TRIANGLES, 0, 3);
    }

    finish(framebuffer, viewport, exposure) {
        const gl = this.gl;
        const { bloom_down: down, bloom_up: up, resolve } = this.programs;
        gl.disable(gl.DEPTH_TEST);
        gl.disable(gl.BLEND);
        let source = this.sceneTexture;
        let sourceSize = this.size;
        for (const level of this.levels) {
            this.pass(down, source, sourceSize, level.framebuffer, level.size);
            source = level.texture;
            sourceSize = level.size;
        }
        gl.enable(gl.BLEND);
        gl.blendFunc(gl.ONE, gl.ONE);
        gl.useProgram(up.handle);
        up.set('u_radius', this.post.upsample_radius);
        for (let i = this.levels.length - 1; i > 0; --i) {
            const smaller = this.levels[i];
            const larger = this.levels[i - 1];
            this.pass(up, smaller.texture, smaller.size, larger.framebuffer, larger.size);
        }
        gl.disable(gl.BLEND);
        gl.useProgram(resolve.handle);
        gl.activeTexture(gl.TEXTURE1);
        gl.bindTexture(gl.TEXTURE_2D, this.levels[0].texture);
        resolve.setAll({
            u_bloom: 1,
            u_bloom_strength: this.post.bloom_strength,
            u_bloom_normalisation: 1 / this.post.bloom_levels,
            u_exposure: exposure,
            u_tone_map: true,
        });
        this.pass(resolve, this.sceneTexture, this.size, framebuffer, viewport.slice(2),
                  viewport.slice(0, 2));
    }

    release() {
        if (!this.size) return;
        const gl = this.gl;
        gl.deleteFramebuffer(this.sceneFramebuffer);
        gl.deleteTexture(this.sceneTexture);
        gl.deleteRenderbuffer(this.depth);
        for (const level of this.levels) {
            gl.deleteFramebuffer(level.framebuffer);
            gl.deleteTexture(level.texture);
        }
        this.size = null;
    }
}

// ---- the scene --------------------------------------------------------------------------------

async function fetchChecked(url, kind) {
    const response = await fetch(url);
    if (!response.ok) throw new Error(`${url}: ${response.status} ${response.statusText}`);
    return kind === 'json' ? response.json() : response.arrayBuffer();
}

// The camera of the renderer's camera_at_distance: looking at the ground at the origin from
// distance_m metres, down at pitch_deg, towards heading_deg (0 = north, −z).
export function orbitCamera(scene, distance, pitchDeg, headingDeg, aspect, fovYDeg = 60) {
    const origin = scene.terrain.origin;
    const target = [0, origin[1], 0];
    const pitch = (pitchDeg * Math.PI) / 180;
    const heading = (headingDeg * Math.PI) / 180;
    const forward = [Math.cos(pitch) * Math.sin(heading), -Math.sin(pitch),
                     -Math.cos(pitch) * Math.cos(heading)];
    const eye = sub(target, scale(forward, distance));
    const up = pitchDeg > 89.9 ? [Math.sin(heading), 0, -Math.cos(heading)] : [0, 1, 0];
    const near = Math.min(Math.max(1e-4, 0.05 * distance), 0.5 * distance);
    const far = Math.max(5000, 100 * distance);
    return {
        view: mat4.lookAt(eye, target, up),
        projection: mat4.perspective(fovYDeg, aspect, near, far),
        eye,
    };
}

export class SandViewer {
    static async create(canvas, base = '.') {
        const root = base.endsWith('/') ? base : `${base}/`;
        const scene = await fetchChecked(`${root}scene.json`, 'json');
        const files = new Set([scene.terrain.vertices, scene.terrain.indices,
                               scene.locomotion.heights,
                               ...scene.material.textures.map((t) => t.file)]);
        const buffers = new Map(await Promise.all(
            [...files].map(async (file) => [file, await fetchChecked(root + file, 'buffer')])));
        return new SandViewer(canvas, scene, buffers);
    }

    constructor(canvas, scene, buffers) {
        const gl = canvas.getContext('webgl2', {
            antialias: false, depth: true, alpha: false, xrCompatible: true,
            preserveDrawingBuffer: false,
        });
        if (!gl) throw new Error('this browser has no WebGL2');
        if (!gl.getExtension('EXT_color_buffer_float')) {
            throw new Error('this browser cannot draw into float targets (EXT_color_buffer_float)');
        }
        this.canvas = canvas;
        this.gl = gl;
        this.scene = scene;
        this.floatLinear = Boolean(gl.getExtension(FLOAT_LINEAR));
        this.programs = {};
        for (const [name, source] of Object.entries(scene.programs)) {
            this.programs[name] = new Program(gl, name, source);
        }
        this.textures = scene.material.textures.map(
            (entry) => uploadTexture(gl, entry, buffers.get(entry.file), this.floatLinear));
        this.halvedTextures = this.textures.filter((t) => t.halved).length;
        this.surfaces = [this.programs.surface, this.programs.surface_far];
        this.terrain = this.makeTerrain(buffers);
        this.post = new PostChain(gl, this.programs, scene.post);
        this.skyVao = gl.createVertexArray();
        this.heights = new Float32Array(buffers.get(scene.locomotion.heights));
        this.onTimeChange = null;  // called with the hours when VR's stick scrubs the day
        this.setTime(10);
        this.xrFrames = 0;
        this.session = null;
        this.afterXRFrame = null;
        this.prepareSurfaces();
    }

    makeTerrain(buffers) {
        const gl = this.gl;
        const terrain = this.scene.terrain;
        const vertices = gl.createBuffer();
        gl.bindBuffer(gl.ARRAY_BUFFER, vertices);
        gl.bufferData(gl.ARRAY_BUFFER, buffers.get(terrain.vertices), gl.STATIC_DRAW);
        const indices = gl.createBuffer();
        const vaos = this.surfaces.map((program) => {
            const vao = gl.createVertexArray();
            gl.bindVertexArray(vao);
            gl.bindBuffer(gl.ARRAY_BUFFER, vertices);
            let offset = 0;
            for (const attribute of terrain.attributes) {
                const location = gl.getAttribLocation(program.handle, attribute.name);
                if (location >= 0) {
                    gl.enableVertexAttribArray(location);
                    gl.vertexAttribPointer(location, attribute.size, gl.FLOAT, false,
                                           terrain.stride_floats * 4, offset * 4);
                }
                offset += attribute.size;
            }
            gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, indices);
            if (program === this.surfaces[0]) {
                gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, buffers.get(terrain.indices), gl.STATIC_DRAW);
            }
            return vao;
        });
        gl.bindVertexArray(null);
        return { vaos, count: terrain.index_count, origin: terrain.origin };
    }

    // The material's textures and uniforms and the renderer's switches: set once.
    prepareSurfaces() {
        const gl = this.gl;
        const units = new Map(this.scene.material.textures.map((t, unit) => [t.uniform, unit]));
        for (const program of this.surfaces) {
            gl.useProgram(program.handle);
            for (const sampler of program.samplers()) {
                program.set(sampler, units.has(sampler) ? units.get(sampler) : SHADOW_UNIT);
            }
            program.setAll(this.scene.material.uniforms);
            program.setAll(this.scene.surface.switches);
            program.setAll({ u_shadow_cascades: 0, u_no_ripples: this.scene.terrain.no_ripples });
        }
        const sky = this.programs.sky;
        gl.useProgram(sky.handle);
        sky.setAll(this.scene.sky.constants);
    }

    // The sky at ``hours`` (0–24, local solar time), between the table's two nearest entries.
    setTime(hours) {
        const table = this.scene.sky.table;
        const clamped = Math.min(Math.max(Number(hours) || 0, 0), 24);
        const step = table[1].hours - table[0].hours;
        const i = Math.min(Math.floor(clamped / step), table.length - 2);
        const t = (clamped - table[i].hours) / step;
        const a = table[i];
        const b = table[i + 1];
        const uniforms = {};
        for (const [name, va] of Object.entries(a.uniforms)) {
            const vb = b.uniforms[name];
            if (Array.isArray(va)) {
                let mixed = va.map((x, k) => x + (vb[k] - x) * t);
                if (name.endsWith('_direction')) mixed = scale(mixed, 1 / Math.hypot(...mixed));
                uniforms[name] = mixed;
            } else {
                uniforms[name] = va + (vb - va) * t;
            }
        }
        this.hours = clamped;
        this.skyUniforms = uniforms;
        this.exposure = Math.exp(Math.log(a.exposure) * (1 - t) + Math.log(b.exposure) * t);
    }

    // One frame of ``camera`` ({view, projection, eye}: column-major matrices, world eye)
    // into ``viewport`` [x, y, w, h] of ``framebuffer`` (null: the canvas).
    drawFrame(camera, framebuffer, viewport) {
        const gl = this.gl;
        const [, , width, height] = viewport;
        this.post.resize(width, height);
        gl.bindFramebuffer(gl.FRAMEBUFFER, this.post.sceneFramebuffer);
        gl.viewport(0, 0, width, height);
        gl.disable(gl.BLEND);
        gl.depthMask(true);
        gl.clearColor(0, 0, 0, 0);  // alpha: no spread (tone.glsl)
        gl.clearDepth(1);
        gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
        this.drawSky(camera, width, height);
        this.drawTerrain(camera);
        this.post.finish(framebuffer, viewport, this.exposure);
    }

    drawSky(camera, width, height) {
        const gl = this.gl;
        const rotation = Float64Array.from(camera.view);
        rotation[12] = rotation[13] = rotation[14] = 0;
        const inverse = mat4.invert(mat4.multiply(camera.projection, rotation));
        const sky = this.programs.sky;
        gl.disable(gl.DEPTH_TEST);
        gl.useProgram(sky.handle);
        sky.set('u_inverse_view_projection', inverse);
        sky.set('u_resolution', [width, height]);
        sky.setAll(this.skyUniforms);
        gl.bindVertexArray(this.skyVao);
        gl.drawArrays(gl.TRIANGLES, 0, 3);
    }

    drawTerrain(camera) {
        const gl = this.gl;
        gl.enable(gl.DEPTH_TEST);
        gl.depthFunc(gl.LESS);
        this.textures.forEach((texture, unit) => {
            gl.activeTexture(gl.TEXTURE0 + unit);
            gl.bindTexture(texture.target, texture.texture);
        });
        const origin = this.terrain.origin;
        // Positions are relative to the mesh's origin: the translation goes into the matrix
        // (in doubles), so float32 keeps millimetres anywhere.
        const relative = mat4.multiply(camera.view, mat4.translation(...origin));
        const viewProjection = mat4.multiply(camera.projection, relative);
        const surfaceSky = Object.fromEntries(
            this.scene.surface.sky.map((name) => [name, this.skyUniforms[name]]));
        this.surfaces.forEach((program, index) => {
            gl.useProgram(program.handle);
            program.setAll(surfaceSky);
            program.set('u_eye', camera.eye);
            program.set('u_view_projection', viewProjection);
            program.set('u_origin', origin);
            gl.bindVertexArray(this.terrain.vaos[index]);
            gl.drawElements(gl.TRIANGLES, this.terrain.count, gl.UNSIGNED_INT, 0);
        });
        gl.bindVertexArray(null);
        gl.disable(gl.DEPTH_TEST);
    }

    // Draw ``camera`` onto the whole canvas and read it back: RGBA8 rows bottom-up.
    renderView(camera) {
        const gl = this.gl;
        const viewport = [0, 0, gl.drawingBufferWidth, gl.drawingBufferHeight];
        this.drawFrame(camera, null, viewport);
        const pixels = new Uint8Array(viewport[2] * viewport[3] * 4);
        gl.bindFramebuffer(gl.FRAMEBUFFER, null);
        gl.readPixels(0, 0, viewport[2], viewport[3], gl.RGBA, gl.UNSIGNED_BYTE, pixels);
        return pixels;
    }

    // The ground's height at (x, z), bilinear in the exported heights (within the walkable
    // square; its edge beyond).
    groundHeight(x, z) {
        const { samples: n, walk_radius_m: r } = this.scene.locomotion;
        const toGrid = (v) => Math.min(Math.max(((v + r) / (2 * r)) * (n - 1), 0), n - 1.000001);
        const gx = toGrid(x);
        const gz = toGrid(z);
        const x0 = Math.floor(gx);
        const z0 = Math.floor(gz);
        const fx = gx - x0;
        const fz = gz - z0;
        const h = (i, j) => this.heights[j * n + i];
        const top = h(x0, z0) * (1 - fx) + h(x0 + 1, z0) * fx;
        const bottom = h(x0, z0 + 1) * (1 - fx) + h(x0 + 1, z0 + 1) * fx;
        return top * (1 - fz) + bottom * fz;
    }

    // ---- WebXR --------------------------------------------------------------------------------

    static async vrSupported() {
        try {
            return Boolean(navigator.xr) && await navigator.xr.isSessionSupported('immersive-vr');
        } catch {
            return false;
        }
    }

    // Stand on the sand at the page's origin, the floor on the ground. ``scale`` sizes the
    // eyes' images against the headset's own (below 1: fewer pixels, faster frames).
    async enterVR({ scale = 1 } = {}) {
        if (this.session) return this.session;
        const gl = this.gl;
        const session = await navigator.xr.requestSession('immersive-vr', {
            optionalFeatures: ['local-floor'],
        });
        await gl.makeXRCompatible();
        const factor = Math.min(Math.max(Number(scale) || 1, 0.25), 1);
        const layer = new XRWebGLLayer(session, gl, { antialias: false, framebufferScaleFactor: factor });
        if ('fixedFoveation' in layer) layer.fixedFoveation = 1;  // fewer pixels at the edges
        session.updateRenderState({ baseLayer: layer });
        let floor = 0;
        let space;
        try {
            space = await session.requestReferenceSpace('local-floor');
        } catch {
            space = await session.requestReferenceSpace('local');
            floor = 1.6;  // a 'local' space starts at the eyes: put them at standing height
        }
        // The headset's space → the world: turned by yaw about +y, its floor on the ground at
        // (x, z); the sticks walk and turn it (see moveXR).
        this.xrFloor = floor;
        this.xr = { x: 0, z: 0, yaw: 0, turnArmed: true, lastTime: null };
        this.session = session;
        this.xrSpace = space;
        session.addEventListener('end', () => { this.session = null; });
        session.requestAnimationFrame((t, frame) => this.onXRFrame(t, frame));
        return session;
    }

    // The world from the headset's space: T(x, ground + floor, z) · Ry(yaw), column-major.
    worldFromHeadset() {
        const { x, z, yaw } = this.xr;
        const c = Math.cos(yaw);
        const s = Math.sin(yaw);
        const m = mat4.identity();
        m[0] = c; m[2] = -s; m[8] = s; m[10] = c;
        m[12] = x;
        m[13] = this.groundHeight(x, z) + this.xrFloor;
        m[14] = z;
        return m;
    }

    // The sticks, as the VR viewer's: left sideways scrubs the day, right sideways snap-turns,
    // right forward and back walks where the head looks.
    moveXR(time, frame, pose) {
        const xr = this.xr;
        const loco = this.scene.locomotion;
        const dt = xr.lastTime === null ? 0 : Math.min(Math.max((time - xr.lastTime) / 1000, 0), 0.1);
        xr.lastTime = time;
        for (const source of frame.session.inputSources) {
            const pad = source.gamepad;
            if (!pad || pad.axes.length < 4) continue;
            const sx = pad.axes[2];
            const sy = pad.axes[3];
            if (source.handedness === 'left' && Math.abs(sx) > loco.dead_zone) {
                this.setTime((((this.hours + sx * loco.scrub_hours_per_s * dt) % 24) + 24) % 24);
                if (this.onTimeChange) this.onTimeChange(this.hours);
            }
            if (source.handedness !== 'right') continue;
            if (xr.turnArmed && Math.abs(sx) > loco.stick_engage) {
                xr.yaw -= Math.sign(sx) * (loco.snap_turn_deg * Math.PI) / 180;
                xr.turnArmed = false;
            } else if (Math.abs(sx) < loco.stick_release) {
                xr.turnArmed = true;
            }
            if (Math.abs(sy) > loco.dead_zone) {
                // The head's forward (−z of its pose) on the ground, turned into the world.
                const q = pose.transform.orientation;
                const fx = -2 * (q.x * q.z + q.w * q.y);
                const fz = -(1 - 2 * (q.x * q.x + q.y * q.y));
                const length = Math.hypot(fx, fz);
                if (length > 1e-6) {
                    const c = Math.cos(xr.yaw);
                    const s = Math.sin(xr.yaw);
                    const wx = (c * fx + s * fz) / length;
                    const wz = (-s * fx + c * fz) / length;
                    const step = -sy * loco.walk_speed_m_s * dt;
                    xr.x += wx * step;
                    xr.z += wz * step;
                    const out = Math.hypot(xr.x, xr.z) / loco.walk_radius_m;
                    if (out > 1) { xr.x /= out; xr.z /= out; }
                }
            }
        }
    }

    onXRFrame(time, frame) {
        const session = frame.session;
        if (session !== this.session) return;
        session.requestAnimationFrame((t, f) => this.onXRFrame(t, f));
        const pose = frame.getViewerPose(this.xrSpace);
        if (!pose) return;
        this.moveXR(time, frame, pose);
        const layer = session.renderState.baseLayer;
        const world = this.worldFromHeadset();
        const toHeadset = mat4.invert(world);
        const views = [];
        for (const view of pose.views) {
            const viewport = layer.getViewport(view);
            if (!(viewport.width >= 1 && viewport.height >= 1)) continue;  // an eye not shown
            const p = view.transform.position;
            const eye = mat4.multiply(world, mat4.translation(p.x, p.y, p.z)).slice(12, 15);
            const camera = {
                view: mat4.multiply(Float64Array.from(view.transform.inverse.matrix), toHeadset),
                projection: Float64Array.from(view.projectionMatrix),
                eye: Array.from(eye),
            };
            const rect = [viewport.x, viewport.y, viewport.width, viewport.height];
            this.drawFrame(camera, layer.framebuffer, rect);
            views.push({ eye: view.eye, viewport: rect, position: camera.eye });
        }
        this.xrFrames += 1;
        if (this.afterXRFrame) this.afterXRFrame(layer, views);
    }
}
