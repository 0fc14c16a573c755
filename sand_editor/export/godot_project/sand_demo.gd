# The sand on its dunes, as the editor shows it: drag to look around, scroll to come closer or
# go further, and the slider sets the time of day.
#
# Run with `-- --views FILE.json --capture DIR` it draws each view of FILE.json (a list of
# {"eye": [x, y, z], "basis": [x axis, y axis, z axis as 9 numbers], "fov_y_deg", "near", "far",
# "hours"}) into DIR/view-N.png, prints each frame's time and quits; with
# `-- --screenshot FILE.png` it saves the window as a user first sees it and quits.
extends Node3D

const Sand := preload("res://sand_material.gd")

var sand: Sand
var camera := Camera3D.new()
var environment := Environment.new()
var slider := HSlider.new()
var label := Label.new()
var distance := 3.0
var pitch := 25.0
var heading := 0.0
var dragging := false


func _ready() -> void:
	sand = Sand.new(get_script().resource_path.get_base_dir())
	if sand.material == null:
		get_tree().quit(1)
		return
	add_child(sand.make_terrain())
	environment.background_mode = Environment.BG_SKY
	environment.sky = sand.sky
	environment.tonemap_mode = Environment.TONE_MAPPER_LINEAR
	var world := WorldEnvironment.new()
	world.environment = environment
	add_child(world)
	add_child(camera)
	camera.make_current()
	var args := _user_args()
	if args.has("views"):
		await _capture(args.views, args.get("capture", "."))
		return
	_build_controls()
	_set_hours(16.5)
	_place_camera()
	if args.has("screenshot"):
		for i in 3:
			await RenderingServer.frame_post_draw
		get_viewport().get_texture().get_image().save_png(args.screenshot)
		get_tree().quit(0)


func _user_args() -> Dictionary:
	var args := {}
	var list := OS.get_cmdline_user_args()
	for i in range(0, list.size() - 1, 2):
		args[list[i].trim_prefix("--")] = list[i + 1]
	return args


func _set_hours(hours: float) -> void:
	sand.set_time(hours)
	label.text = "%02d:%02d" % [int(hours), int(fmod(hours, 1.0) * 60.0)]


func _build_controls() -> void:
	var layer := CanvasLayer.new()
	var box := HBoxContainer.new()
	box.position = Vector2(16, 16)
	slider.min_value = 0.0
	slider.max_value = 24.0
	slider.step = 1.0 / 60.0
	slider.value = 16.5
	slider.custom_minimum_size = Vector2(320, 24)
	slider.value_changed.connect(_set_hours)
	box.add_child(label)
	box.add_child(slider)
	layer.add_child(box)
	add_child(layer)


func _place_camera() -> void:
	var p := deg_to_rad(pitch)
	var h := deg_to_rad(heading)
	var forward := Vector3(cos(p) * sin(h), -sin(p), -cos(p) * cos(h))
	var target := Vector3(0.0, sand.scene.terrain.origin[1], 0.0)
	camera.near = distance * 0.05
	camera.far = maxf(5000.0, distance * 100.0)
	camera.fov = 60.0
	camera.look_at_from_position(target - forward * distance, target, Vector3.UP)


func _unhandled_input(event: InputEvent) -> void:
	if event is InputEventMouseButton:
		if event.button_index == MOUSE_BUTTON_LEFT:
			dragging = event.pressed
		elif event.button_index == MOUSE_BUTTON_WHEEL_UP:
			distance = maxf(distance / 1.15, 0.02)
		elif event.button_index == MOUSE_BUTTON_WHEEL_DOWN:
			distance = minf(distance * 1.15, 300.0)
		_place_camera()
	elif event is InputEventMouseMotion and dragging:
		heading -= event.relative.x * 0.3
		pitch = clampf(pitch + event.relative.y * 0.3, 2.0, 89.0)
		_place_camera()


func _capture(views_file: String, folder: String) -> void:
	var views = JSON.parse_string(FileAccess.get_file_as_string(views_file))
	if typeof(views) != TYPE_ARRAY:
		push_error("Sand: %s holds no list of views" % views_file)
		get_tree().quit(1)
		return
	var index := 0
	for view in views:
		var b: Array = view.basis
		var basis := Basis(Vector3(b[0], b[1], b[2]), Vector3(b[3], b[4], b[5]), Vector3(b[6], b[7], b[8]))
		camera.transform = Transform3D(basis, Vector3(view.eye[0], view.eye[1], view.eye[2]))
		camera.fov = view.fov_y_deg
		camera.near = view.near
		camera.far = view.far
		_set_hours(view.hours)
		await RenderingServer.frame_post_draw
		var start := Time.get_ticks_usec()
		await RenderingServer.frame_post_draw
		var ms := (Time.get_ticks_usec() - start) / 1000.0
		var image := get_viewport().get_texture().get_image()
		var path := folder.path_join("view-%d.png" % index)
		image.save_png(path)
		print("SAND_CAPTURE %d %s %.1f" % [index, path, ms])
		index += 1
	get_tree().quit(0)
