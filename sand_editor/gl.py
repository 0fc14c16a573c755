"""OpenGL contexts and programs: the one place that knows how to get a moderngl context."""

from __future__ import annotations

import ctypes
import ctypes.util
import re
import threading
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from functools import cache

import moderngl
import numpy as np

from sand_editor.colour import SHADER_DEFINES as COLOUR_DEFINES
from sand_editor.resources import bench_shaders_dir, shader_source, shaders_dir

REQUIRED_GL_VERSION = 330
_local = threading.local()


class GLUnavailableError(RuntimeError):
    """No OpenGL 3.3 context could be created (no EGL/GL driver on this machine)."""


def standalone_context() -> moderngl.Context:
    """A headless context (EGL), one per thread, created on first use.

    EGL needs no display, so this works on servers and in CI (Mesa's llvmpipe). GL calls go to
    the thread's current context, so code that has a context of its own (a Qt window's) passes
    that one to the generator instead, and no other standalone context is made on this thread.
    """
    ctx = getattr(_local, "ctx", None)
    if ctx is None:
        ctx = headless_context()
        _local.ctx = ctx
        _local.egl_handle = _current_egl_context()
    elif _current_egl_context() != _local.egl_handle:
        # A window's context was current since (see standalone_current): ours comes back.
        ctx.__enter__()
    return ctx


def headless_context() -> moderngl.Context:
    """A new headless (EGL) context, current on this thread, owned by the caller (who releases
    it); ``standalone_context`` keeps one per thread instead."""
    try:
        return moderngl.create_standalone_context(require=REQUIRED_GL_VERSION, backend="egl")
    except Exception as exc:  # moderngl raises bare Exceptions for missing drivers
        raise GLUnavailableError(
            "cannot create a headless OpenGL 3.3 context through EGL: "
            f"{exc}. On Debian install libegl1 and libgl1-mesa-dri."
        ) from exc


@contextmanager
def standalone_current() -> Iterator[moderngl.Context]:
    """The headless context, current for the block and released after it.

    libglvnd refuses to make a GLX context (a Qt window's) current while an EGL context is
    current on the same thread, and the other way round: code that shares its thread with a
    window's context uses the headless one only inside this block, with the window's released.
    """
    ctx = standalone_context()
    try:
        yield ctx
    finally:
        release_standalone_context()


def release_standalone_context() -> None:
    """Make no EGL context current on this thread (a no-op where none is)."""
    egl = egl_library()
    if egl is not None and egl.eglGetCurrentContext():
        egl.eglMakeCurrent(egl.eglGetCurrentDisplay(), None, None, None)


def egl_library():
    """libEGL with the signatures this project calls (None where it cannot be loaded)."""
    if not hasattr(_local, "egl"):
        name = ctypes.util.find_library("EGL") or "libEGL.so.1"
        try:
            egl = ctypes.CDLL(name)
        except OSError:
            egl = None
        else:
            pointer, integer, flag = ctypes.c_void_p, ctypes.c_int32, ctypes.c_uint
            attributes, out = ctypes.POINTER(integer), ctypes.POINTER
            signatures = {
                "eglGetCurrentDisplay": (pointer, []),
                "eglGetCurrentContext": (pointer, []),
                "eglGetError": (integer, []),
                "eglBindAPI": (flag, [ctypes.c_uint]),
                "eglChooseConfig": (
                    flag,
                    [pointer, attributes, out(pointer), integer, out(integer)],
                ),
                "eglCreateContext": (pointer, [pointer, pointer, pointer, attributes]),
                "eglMakeCurrent": (flag, [pointer, pointer, pointer, pointer]),
                "eglDestroyContext": (flag, [pointer, pointer]),
                "eglGetProcAddress": (pointer, [ctypes.c_char_p]),
            }
            for function_name, (restype, argtypes) in signatures.items():
                function = getattr(egl, function_name)
                function.restype = restype
                function.argtypes = argtypes
        _local.egl = egl
    return _local.egl


def _current_egl_context() -> int | None:
    egl = egl_library()
    return egl.eglGetCurrentContext() if egl is not None else None


@cache
def _gl_function(name: str, *argtypes):
    """A GL entry point of whatever context is current on the calling thread.

    libglvnd's libOpenGL dispatches to the current context whether EGL or GLX made it current;
    libGL (which also carries GLX) does too and is the fallback where libOpenGL is missing.
    """
    for library in (ctypes.util.find_library("OpenGL"), ctypes.util.find_library("GL")):
        if library:
            break
    else:
        library = "libGL.so.1"
    function = getattr(ctypes.CDLL(library), name)
    function.restype = None
    function.argtypes = list(argtypes)
    return function


_GL_FRAMEBUFFER = 0x8D40
_GL_DEPTH_ATTACHMENT = 0x8D00
_GL_DEPTH_STENCIL_ATTACHMENT = 0x821A


def attach_depth_texture(framebuffer: moderngl.Framebuffer, texture: int, stencil: bool) -> None:
    """Attach GL texture ``texture`` (a depth format made elsewhere, e.g. a compositor's
    swapchain image, which moderngl cannot wrap as a depth texture) as ``framebuffer``'s depth
    (and stencil) buffer, and let the framebuffer write depth."""
    attachment = _GL_DEPTH_STENCIL_ATTACHMENT if stencil else _GL_DEPTH_ATTACHMENT
    framebuffer.use()
    attach = _gl_function(
        "glFramebufferTexture2D",
        ctypes.c_uint, ctypes.c_uint, ctypes.c_uint, ctypes.c_uint, ctypes.c_int,
    )  # fmt: skip
    attach(_GL_FRAMEBUFFER, attachment, _GL_TEXTURE_2D, int(texture), 0)
    framebuffer.depth_mask = True


def finish_without_gil() -> None:
    """``glFinish`` on this thread's current context, letting other Python threads run while
    it waits.

    moderngl keeps Python's lock while it waits on GL (``finish``, ``read``,
    ``build_mipmaps``); a call through ctypes releases it. On a CPU rasterizer the waiting is
    the drawing itself, so a thread drawing frames and one making new grains then draw at the
    same time instead of taking turns.
    """
    _gl_function("glFinish")()


def build_mipmaps_without_gil(texture: moderngl.Texture) -> None:
    """Rebuild the mip levels of a 2D texture from its base level, letting other Python
    threads run meanwhile (``Texture.build_mipmaps`` waits for each level holding the lock).

    The texture must have had ``build_mipmaps`` called once (which sets its filter and the
    levels moderngl lets ``read`` address); the texture stays bound to unit 0.
    """
    finish_without_gil()  # the draws into the base level
    texture.use(location=0)
    _gl_function("glGenerateMipmap", ctypes.c_uint)(_GL_TEXTURE_2D)
    finish_without_gil()


def read_without_gil(texture: moderngl.Texture, **kwargs) -> bytes:
    """``texture.read(**kwargs)``, once the draws into it are done without holding Python's
    lock: only the copy itself then holds it."""
    finish_without_gil()
    return texture.read(**kwargs)


_GL_TEXTURE_2D = 0x0DE1
# #include "file", or #include "file" if NAME: only in programs compiled with NAME defined (the
# benchmark's probe code, which production programs must not even contain).
_INCLUDE = re.compile(r'^[ \t]*#include[ \t]+"([^"]+)"(?:[ \t]+if[ \t]+(\w+))?[ \t]*$', re.M)


class ShaderSourceError(ValueError):
    """A shader file names an include that does not exist, or includes itself."""


# Each file of a program numbers its lines from its own base: `#line` directives keep the
# compiler's line numbers those of the file (the first file's own, file k's k·LINE_STRIDE more),
# so a compile error can name the file and line. GLSL's #line takes a source number too, but
# drivers do not all report it.
LINE_STRIDE = 100_000
# Mesa writes "0:LINE(COLUMN)", NVIDIA "0(LINE)".
_MESA_LINE = re.compile(r"\b\d+:(\d+)\((\d+)\)")
_NVIDIA_LINE = re.compile(r"\b\d+\((\d+)\)")


# The one dialect the shaders are written in, and what makes the same text GLSL ES 3.00
# (WebGL2, OpenGL ES 3): the version line and default precisions, highest everywhere (the
# glint moments subtract nearly equal numbers; mediump would round them away).
CORE_VERSION = "#version 330 core"
ES_HEADER = "\n".join(
    (
        "#version 300 es",
        "precision highp float;",
        "precision highp int;",
        *(
            f"precision highp {sampler};"
            for sampler in (
                "sampler2D", "sampler3D", "sampler2DArray", "sampler2DShadow",
                "sampler2DArrayShadow", "usampler2D", "isampler2D",
            )
        ),
    )
)  # fmt: skip
DIALECTS = ("core", "es")


def shader_text(
    name: str, defines: Mapping[str, object] | None = None, dialect: str = "core"
) -> str:
    """GLSL source of a file in ``shaders/`` with its ``#include "…"`` lines resolved and
    ``defines`` (after the colour facts every program gets) inserted after its ``#version``
    line.

    Each file is included once per program (later includes of it are dropped), so shared
    libraries can include what they use. ``#include "file" if NAME`` includes the file only
    when ``defines`` holds NAME. ``#line`` directives number each file's lines as its own
    (see :func:`source_line`).

    ``dialect="es"`` gives the same program as GLSL ES 3.00 (WebGL2): one source for both,
    never a copy; the line numbers stay those of the core text.
    """
    text = _expand(name, defines)[0]
    if dialect == "core":
        return text
    if dialect != "es":
        raise ValueError(f"unknown GLSL dialect {dialect!r}; allowed {', '.join(DIALECTS)}")
    header, _, body = text.partition("\n")
    if header.strip() != CORE_VERSION:
        raise ShaderSourceError(f"shaders/{name}: starts {header!r}, not {CORE_VERSION!r}")
    return f"{ES_HEADER}\n{body}"


def _expand(name: str, defines: Mapping[str, object] | None) -> tuple[str, tuple[str, ...]]:
    # Facts every program shares (colour.py's luminance weights and sRGB curve) come first.
    defines = {**COLOUR_DEFINES, **(defines or {})}
    seen: set[str] = set()
    files: list[str] = []
    defined = set(defines or ())

    def include(match: re.Match, chain: tuple[str, ...], base: int, text: str) -> str:
        file, condition = match.group(1), match.group(2)
        if condition is not None and condition not in defined:
            return ""
        body = expand(file, chain)
        if not body:
            return ""
        after = text.count("\n", 0, match.start()) + 2  # the parent's line after the include
        return f"{body}\n#line {base + after}"

    def expand(file: str, chain: tuple[str, ...]) -> str:
        if file in chain:
            raise ShaderSourceError(f"shaders/{file}: includes itself via {' -> '.join(chain)}")
        if file in seen:
            return ""
        seen.add(file)
        try:
            text = shader_source(file)
        except FileNotFoundError:
            where = f" (included from shaders/{chain[-1]})" if chain else ""
            raise ShaderSourceError(f"shaders/{file}: no such shader file{where}") from None
        base = len(files) * LINE_STRIDE
        files.append(file)
        body = _INCLUDE.sub(lambda m: include(m, (*chain, file), base, text), text)
        return body if not chain else f"#line {base + 1}\n{body}"

    source = expand(name, ())
    header, _, body = source.partition("\n")
    lines = "".join(f"#define {key} {value}\n" for key, value in (defines or {}).items())
    return f"{header}\n{lines}#line 2\n{body}", tuple(files)


def source_line(name: str, defines: Mapping[str, object] | None, line: int) -> str:
    """Where line ``line`` of the compiled ``shader_text(name, defines)``, as the compiler
    numbers it, comes from: ``shaders/FILE:LINE``."""
    files = _expand(name, defines)[1]
    index, own = divmod(line, LINE_STRIDE)
    if not 0 <= index < len(files):
        return f"line {line}"
    return f"shaders/{files[index]}:{own}"


def _located(message: str, name: str, defines: Mapping[str, object] | None) -> str:
    """A compiler's message with each line number it names as the shader file and line."""
    files = _expand(name, defines)[1]

    def where(match: re.Match) -> str:
        index, own = divmod(int(match.group(1)), LINE_STRIDE)
        if not 0 <= index < len(files):
            return match.group(0)
        column = f":{match.group(2)}" if match.lastindex == 2 else ""
        return f"shaders/{files[index]}:{own}{column}"

    return _NVIDIA_LINE.sub(where, _MESA_LINE.sub(where, message))


_UNIFORM = re.compile(r"^[ \t]*uniform[ \t]+\w+[ \t]+(\w+)", re.M)


class UniformError(KeyError):
    """A uniform that no shader declares: a misspelt name, never an optimised-out one."""


@cache
def declared_uniforms() -> frozenset[str]:
    """Every uniform name declared by a shader file the product or its benchmark ships."""
    files = [*shaders_dir().glob("*.*"), *bench_shaders_dir().glob("*.*")]
    return frozenset(
        name for path in files for name in _UNIFORM.findall(path.read_text(encoding="utf-8"))
    )


def _member(program, name: str):
    """The program's uniform ``name``; None when a shader declares it but this program does not
    use it (optimised out, or of another variant); ``UniformError`` when no shader declares it."""
    if name in program:
        return program[name]
    if name not in declared_uniforms():
        raise UniformError(f"no shader declares the uniform {name!r}")
    return None


def set_uniform(program, name: str, value) -> None:
    """Set a uniform the compiler kept; one this program does not use is skipped, one that no
    shader declares raises ``UniformError``, so a misspelt name is never skipped silently."""
    member = _member(program, name)
    if member is not None:
        member.value = value


def set_matrix(program, name: str, matrix) -> None:
    """Set a ``mat4`` uniform (or an array of them, from a stack of matrices) from matrices as
    numpy writes them (rows first; GLSL reads columns), by the rules of :func:`set_uniform`:
    the one way matrices reach a program."""
    member = _member(program, name)
    if member is not None:
        member.write(np.swapaxes(np.asarray(matrix, dtype=np.float32), -1, -2).tobytes())


def program(ctx: moderngl.Context, name: str, defines: Mapping[str, object] | None = None):
    """A program from one file holding both stages, ``#if defined VERTEX_SHADER`` and
    ``#elif defined FRAGMENT_SHADER`` sections (the file is compiled once per stage)."""
    base = dict(defines or {})
    vertex, fragment = {**base, "VERTEX_SHADER": 1}, {**base, "FRAGMENT_SHADER": 1}
    return _compiled(ctx, (name, vertex), (name, fragment))


def fullscreen_program(ctx: moderngl.Context, fragment: str, defines: dict | None = None):
    """Program of the fullscreen triangle and a fragment shader from ``shaders/``."""
    return _compiled(ctx, ("fullscreen.vert", None), (fragment, defines))


# Every program this process compiled, as ((vertex file, defines), (fragment file, defines)):
# what a port of the renderer to another dialect must compile (tests check them all as ES).
compiled_programs: set[tuple] = set()


def _spec(file: str, defines: Mapping[str, object] | None) -> tuple:
    return file, tuple(sorted((defines or {}).items()))


def _compiled(ctx: moderngl.Context, vertex: tuple, fragment: tuple):
    """Compile a program of two shader files (name, defines); a compile error names the file
    and line of each message in it. Only a program that compiled is recorded."""
    try:
        compiled = ctx.program(
            vertex_shader=shader_text(*vertex), fragment_shader=shader_text(*fragment)
        )
    except moderngl.Error as exc:
        message = str(exc)
        head, marker, tail = message.partition("fragment_shader\n")
        located = _located(head, *vertex) + marker + (_located(tail, *fragment) if marker else "")
        raise moderngl.Error(located) from None
    compiled_programs.add((_spec(*vertex), _spec(*fragment)))
    return compiled


@contextmanager
def render_state(ctx: moderngl.Context, flags: int = 0, blend_func=None) -> Iterator[None]:
    """Exactly ``flags`` (``moderngl.DEPTH_TEST | …``) enabled for a block, and none after it:
    a pass never inherits blending, depth testing or culling from another pass or from a host
    (Qt leaves blending on). ``blend_func`` applies for the block, the default after it."""
    ctx.enable_only(flags)
    if blend_func is not None:
        ctx.blend_func = blend_func
    try:
        yield
    finally:
        if blend_func is not None:
            ctx.blend_func = moderngl.DEFAULT_BLENDING
        ctx.enable_only(moderngl.NOTHING)


def draw_fullscreen(ctx: moderngl.Context, program, *, blend: bool = False) -> None:
    """Draw the fullscreen triangle with ``program`` (release it with :func:`release_program`).

    The pass overwrites its target: blending is turned off first (a host's paint callback may
    have left it on; Qt does), unless ``blend`` asks to keep the caller's blending.
    """
    if not blend:
        ctx.disable(moderngl.BLEND)
    vao = _fullscreen_vao(ctx, program)
    vao.render(moderngl.TRIANGLES, vertices=3)


def _fullscreen_vao(ctx, program):
    # Kept on the program itself, never by GL name: a released program's name can be handed
    # to a new program, which must not draw through the old one's vertex array.
    if not isinstance(program.extra, moderngl.VertexArray):
        program.extra = ctx.vertex_array(program, [])
    return program.extra


class GLObjects:
    """The GL objects one owner made, released together, the last made first: ``keep(obj)``
    returns ``obj`` and takes it on; ``release()`` (safe to call twice) releases everything kept,
    a program drawn with :func:`draw_fullscreen` together with its vertex array. Usable as a
    context manager, for objects that live for a block."""

    def __init__(self) -> None:
        self._objects: list = []

    def keep(self, obj):
        self._objects.append(obj)
        return obj

    def release(self) -> None:
        while self._objects:
            obj = self._objects.pop()
            if isinstance(obj, moderngl.Program):
                release_program(obj)
            else:
                obj.release()

    def __enter__(self) -> GLObjects:
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def release_program(program) -> None:
    """Release a program drawn with :func:`draw_fullscreen` and the vertex array it drew with
    (safe to call twice)."""
    vao = program.extra
    program.extra = None
    if isinstance(vao, moderngl.VertexArray):
        vao.release()
    program.release()


@contextmanager
def drawing_into(ctx: moderngl.Context, framebuffer: moderngl.Framebuffer) -> Iterator[None]:
    """Bind ``framebuffer`` for a draw, then bind again whatever was bound before.

    A host window keeps drawing into its own framebuffer, and releasing ours later can never
    leave a deleted framebuffer bound.
    """
    previous = ctx.fbo
    framebuffer.use()
    try:
        yield
    finally:
        # A framebuffer released while bound stays ``ctx.fbo``, with an invalid handle.
        released = isinstance(getattr(previous, "mglo", None), moderngl.InvalidObject)
        if isinstance(previous, moderngl.Framebuffer) and not released:
            previous.use()
        else:  # nothing bound yet (a fresh headless context), or released by its owner
            ctx.detect_framebuffer(0).use()
