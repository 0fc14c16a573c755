"""The viewer's suggested bindings against the runtime: every profile is accepted, and the
runtime does check paths (an unknown one rejects the whole profile), so acceptance means
something."""

from __future__ import annotations

import pytest
import xr

from sand_editor.vr.actions import ACTIONS, BINDINGS, binding_paths
from sand_editor.vr.xr_backend import _ACTION_TYPES, create_instance

pytestmark = pytest.mark.openxr


@pytest.fixture
def actions():
    instance = create_instance()
    try:
        hands = [xr.string_to_path(instance, f"/user/hand/{h}") for h in ("left", "right")]
        action_set = xr.create_action_set(
            instance, xr.ActionSetCreateInfo("bindings_test", "Bindings test", 0)
        )
        created = {
            name: xr.create_action(
                action_set,
                xr.ActionCreateInfo(
                    action_name=name,
                    action_type=_ACTION_TYPES[kind],
                    subaction_paths=hands,
                    localized_action_name=label,
                ),
            )
            for name, (kind, label) in ACTIONS.items()
        }
        yield instance, created
    finally:
        xr.destroy_instance(instance)


def _suggest(instance, created, profile, pairs):
    xr.suggest_interaction_profile_bindings(
        instance,
        xr.InteractionProfileSuggestedBinding(
            interaction_profile=xr.string_to_path(instance, profile),
            suggested_bindings=[
                xr.ActionSuggestedBinding(created[action], xr.string_to_path(instance, path))
                for action, path in pairs
            ],
        ),
    )


@pytest.mark.parametrize("profile", sorted(BINDINGS))
def test_the_runtime_accepts_each_profile(actions, profile):
    instance, created = actions
    _suggest(instance, created, profile, binding_paths(profile))


@pytest.mark.parametrize("profile", sorted(BINDINGS))
def test_one_unknown_path_rejects_the_profile(actions, profile):
    instance, created = actions
    pairs = [*binding_paths(profile), ("select", "/user/hand/left/input/no_such_button/click")]
    with pytest.raises(xr.XrException):
        _suggest(instance, created, profile, pairs)
