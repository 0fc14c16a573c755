# The sand of Sand Editor in Godot 4: the ShaderMaterial, the dunes' mesh and the sky, built from
# the files beside this script (scene.json, the textures' .bin files, sand.gdshader, sky.gdshader) as
# `sand-editor export --format godot` wrote them. Every mip level is the editor's own: the
# textures are made here rather than imported, so Godot neither remakes nor compresses them.
#
#     var sand := preload("res://sand/sand_material.gd").new("res://sand")
#     add_child(sand.make_terrain())   # or: some_mesh.material_override = sand.material
#     sand.set_time(16.5)              # sun, moon, sky light and exposure of that hour
#     environment.sky = sand.sky       # the editor's sky (background_mode = BG_SKY)
#
# In an exported game, add "*.bin, *.json" to the export preset's non-resource filters.
extends RefCounted

const IMAGE_FORMATS := {
	"FORMAT_RF": Image.FORMAT_RF,
	"FORMAT_RGF": Image.FORMAT_RGF,
	"FORMAT_RGBAF": Image.FORMAT_RGBAF,
	"FORMAT_RGBAH": Image.FORMAT_RGBAH,
}

var folder: String
var scene: Dictionary
var material: ShaderMaterial
var sky_material: ShaderMaterial
var sky: Sky
var hours := 12.0
var exposure := 1.0


func _init(path: String = "") -> void:
	folder = path if path != "" else get_script().resource_path.get_base_dir()
	var text := FileAccess.get_file_as_string(folder.path_join("scene.json"))
	var parsed = JSON.parse_string(text)
	if typeof(parsed) != TYPE_DICTIONARY:
		push_error("Sand: %s is missing or not a scene" % folder.path_join("scene.json"))
		return
	scene = parsed
	material = _shader_material("sand.gdshader", scene.material.uniforms)
	sky_material = _shader_material("sky.gdshader", scene.sky.constants)
	sky = Sky.new()
	sky.sky_material = sky_material
	# The sand is lit by its own sun and sky, not Godot's reflections of the sky: the smallest
	# radiance map keeps Forward+ from spending a frame's time on it at every change of hour.
	sky.radiance_size = Sky.RADIANCE_SIZE_32
	for entry in scene.material.textures:
		material.set_shader_parameter(entry.uniform, _texture(entry))
	set_time(hours)


func _shader_material(file: String, uniforms: Array) -> ShaderMaterial:
	var shader := Shader.new()
	shader.code = FileAccess.get_file_as_string(folder.path_join(file))
	var made := ShaderMaterial.new()
	made.shader = shader
	for uniform in uniforms:
		made.set_shader_parameter(uniform.name, _value(uniform.type, uniform.value))
	return made


# A uniform's value as the shader's type takes it (JSON holds every number as a float).
func _value(type: String, value):
	if type.ends_with("]"):
		return PackedFloat32Array(value)
	match type:
		"int", "uint":
			return int(value)
		"bool":
			return bool(value)
		"vec2":
			return Vector2(value[0], value[1])
		"vec3":
			return Vector3(value[0], value[1], value[2])
		"vec4":
			return Vector4(value[0], value[1], value[2], value[3])
	return float(value)


func _texture(entry: Dictionary) -> Texture:
	var data := FileAccess.get_file_as_bytes(folder.path_join(entry.file))
	var size: Array = entry.levels[0].size
	var format: int = IMAGE_FORMATS[entry.image_format]
	if entry.target == "TEXTURE_3D":
		var slice := int(entry.levels[0].bytes) / int(size[2])
		var images: Array[Image] = []
		for z in int(size[2]):
			var part := data.slice(z * slice, (z + 1) * slice)
			images.append(Image.create_from_data(int(size[0]), int(size[1]), false, format, part))
		var volume := ImageTexture3D.new()
		volume.create(format, int(size[0]), int(size[1]), int(size[2]), false, images)
		return volume
	var mipmaps: bool = entry.levels.size() > 1
	var image := Image.create_from_data(int(size[0]), int(size[1]), mipmaps, format, data)
	return ImageTexture.create_from_image(image)


# The sky at `at_hours` (0–24, local solar time), between the table's two nearest entries:
# the light and exposure the renderer uses at that time.
func set_time(at_hours: float) -> void:
	var table: Array = scene.sky.table
	hours = clampf(at_hours, 0.0, 24.0)
	var step: float = table[1].hours - table[0].hours
	var i := mini(int(floor(hours / step)), table.size() - 2)
	var t: float = (hours - table[i].hours) / step
	var a: Dictionary = table[i]
	var b: Dictionary = table[i + 1]
	_mix(material, a.uniforms, b.uniforms, t)
	_mix(sky_material, a.sky_uniforms, b.sky_uniforms, t)
	exposure = exp(lerpf(log(a.exposure), log(b.exposure), t))
	material.set_shader_parameter("u_exposure", exposure)
	sky_material.set_shader_parameter("u_exposure", exposure)


func _mix(target: ShaderMaterial, a: Dictionary, b: Dictionary, t: float) -> void:
	for name in a:
		var va = a[name]
		var vb = b[name]
		if va is Array:
			var mixed := Vector3(va[0], va[1], va[2]).lerp(Vector3(vb[0], vb[1], vb[2]), t)
			if name.ends_with("_direction") and mixed.length() > 0.0:
				mixed = mixed.normalized()
			target.set_shader_parameter(name, mixed)
		else:
			target.set_shader_parameter(name, lerpf(va, vb, t))


# The dunes around the scene's origin as a MeshInstance3D drawn with the sand.
func make_terrain() -> MeshInstance3D:
	var terrain: Dictionary = scene.terrain
	var floats := FileAccess.get_file_as_bytes(folder.path_join(terrain.vertices)).to_float32_array()
	var stride := int(terrain.stride_floats)
	var count := int(terrain.vertex_count)
	var offsets := {}
	var offset := 0
	for attribute in terrain.attributes:
		offsets[attribute.name] = offset
		offset += int(attribute.size)
	var positions := PackedVector3Array()
	var normals := PackedVector3Array()
	var tangents := PackedFloat32Array()
	var uvs := PackedVector2Array()
	# Godot packs NORMAL and TANGENT into 16-bit octahedral pairs; the glints turn on the
	# surface's exact normal, so the shader reads both as floats from CUSTOM0 and CUSTOM1
	# (CUSTOM0.w = 1 says they are there).
	var exact_normals := PackedFloat32Array()
	var exact_tangents := PackedFloat32Array()
	positions.resize(count)
	normals.resize(count)
	tangents.resize(count * 4)
	uvs.resize(count)
	exact_normals.resize(count * 4)
	exact_tangents.resize(count * 4)
	var p: int = offsets.a_position
	var n: int = offsets.a_normal
	var g: int = offsets.a_tangent
	var u: int = offsets.a_uv
	for i in count:
		var o := i * stride
		positions[i] = Vector3(floats[o + p], floats[o + p + 1], floats[o + p + 2])
		normals[i] = Vector3(floats[o + n], floats[o + n + 1], floats[o + n + 2])
		tangents[i * 4] = floats[o + g]
		tangents[i * 4 + 1] = floats[o + g + 1]
		tangents[i * 4 + 2] = floats[o + g + 2]
		tangents[i * 4 + 3] = 1.0
		uvs[i] = Vector2(floats[o + u], floats[o + u + 1])
		for k in 3:
			exact_normals[i * 4 + k] = floats[o + n + k]
			exact_tangents[i * 4 + k] = floats[o + g + k]
		exact_normals[i * 4 + 3] = 1.0  # marks the exact frame as present
	var arrays := []
	arrays.resize(Mesh.ARRAY_MAX)
	arrays[Mesh.ARRAY_VERTEX] = positions
	arrays[Mesh.ARRAY_NORMAL] = normals
	arrays[Mesh.ARRAY_TANGENT] = tangents
	arrays[Mesh.ARRAY_TEX_UV] = uvs
	arrays[Mesh.ARRAY_CUSTOM0] = exact_normals
	arrays[Mesh.ARRAY_CUSTOM1] = exact_tangents
	arrays[Mesh.ARRAY_INDEX] = FileAccess.get_file_as_bytes(folder.path_join(terrain.indices)).to_int32_array()
	var mesh := ArrayMesh.new()
	var exact := (Mesh.ARRAY_CUSTOM_RGBA_FLOAT << Mesh.ARRAY_FORMAT_CUSTOM0_SHIFT) | (
		Mesh.ARRAY_CUSTOM_RGBA_FLOAT << Mesh.ARRAY_FORMAT_CUSTOM1_SHIFT)
	mesh.add_surface_from_arrays(Mesh.PRIMITIVE_TRIANGLES, arrays, [], {}, exact)
	var node := MeshInstance3D.new()
	node.name = "Dunes"
	node.mesh = mesh
	node.material_override = material
	var origin: Array = terrain.origin
	node.position = Vector3(origin[0], origin[1], origin[2])
	return node
