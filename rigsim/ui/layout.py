"""Page layout of the rig designer (trame + Vuetify 3); callbacks live in :mod:`rigsim.ui.app`."""

from __future__ import annotations

from pathlib import Path

__all__ = ["build"]

_STATIC = Path(__file__).with_name("static")


def _num(v3, html, label, var, lo, hi, step, unit, *, slider=True, err=True, hint=None):
    """A caption, a slider and a number field bound to the same variable."""
    html.Div(label, classes="text-caption mt-1", title=hint or "")
    with html.Div(classes="d-flex align-center"):
        if slider:
            v3.VSlider(v_model=(var,), min=lo, max=hi, step=step, hide_details=True, density="compact",
                       color="primary", classes="mr-2")
        kw = {"error_messages": (f"err_{var}",)} if err else {}
        v3.VTextField(v_model=(var,), id=var, type="number", suffix=unit, density="compact", variant="outlined",
                      hide_details="auto", step=step, style="max-width: 132px; min-width: 118px", **kw)


def _metrics_table(v3, html, rows_expr: str, prefix: str | None):
    with v3.VTable(density="compact", classes="rs-metrics"):
        with html.Tbody():
            with html.Tr(v_for=f"row in {rows_expr}", key="row.key"):
                html.Td("{{ row.label }}", title=("row.hint",))
                if prefix:
                    html.Td("{{ row.text }}", classes="v", raw_attrs=[f":id=\"'{prefix}' + row.key\""])
                else:
                    html.Td("{{ row.text }}", classes="v")


def build(app) -> None:
    """Build the page of a :class:`rigsim.ui.app.RigDesigner`."""
    from trame.ui.vuetify3 import SinglePageWithDrawerLayout
    from trame.widgets import html, vtk as vtk_widgets, vuetify3 as v3

    server = app.server
    with SinglePageWithDrawerLayout(server, width=400) as layout:
        layout.title.set_text("rigsim · rig designer")
        server.enable_module({"serve": {"rigsim_ui": str(_STATIC)}, "styles": ["rigsim_ui/rigsim-ui.css"]})
        # ------------------------------------------------------------ toolbar
        with layout.toolbar:
            v3.VChip("{{ engine }}", size="small", classes="ml-4", variant="outlined",
                     title="engine of the live preview")
            v3.VSpacer()
            v3.VSelect(v_model=("render_quality",), items=("render_quality_items",), density="compact",
                       hide_details=True, variant="outlined", style="max-width: 220px", classes="mr-2",
                       label="converged render", id="render-quality")
            v3.VBtn("Render", id="render-btn", click=(app.ctrl.render_converged, "[render_quality]"), color="primary",
                    variant="flat", prepend_icon="mdi-camera-iris", disabled=("render_running",))
            v3.VBtn("Cancel", click=app.ctrl.cancel_render, v_if="render_running", variant="text", classes="ml-1")
            v3.VBtn("Optimise", id="optimise-btn", click=app.ctrl.optimise_rig, variant="outlined", classes="ml-2",
                    prepend_icon="mdi-target", disabled=("optimise_running || render_running",),
                    title="move the lights to where the predicted photograph is best for this water and distance "
                          "(about a minute; the rig as it was is pinned as rig B)")
            v3.VProgressLinear(v_if="optimise_running", model_value=("optimise_progress",), absolute=True,
                               location="bottom", color="teal", height=4)
            v3.VProgressLinear(v_if="render_running", model_value=("render_progress",), absolute=True,
                               location="bottom", color="amber", height=4)

        # ------------------------------------------------------------ drawer: controls
        with layout.drawer:
            with v3.VExpansionPanels(multiple=True, v_model=("panels", ["lights", "water", "subject"]), variant="accordion"):
                # --- rig file
                with v3.VExpansionPanel(title="Rig file", value="file"):
                    with v3.VExpansionPanelText():
                        with html.Div(classes="d-flex align-center"):
                            v3.VSelect(v_model=("file_sel",), items=("file_items",), label="open",
                                       density="compact", hide_details=True, variant="outlined", id="file-sel")
                            v3.VBtn("Load", click=(app.ctrl.load_rig, "[file_sel]"), classes="ml-2", size="small", id="load-btn")
                        with html.Div(classes="d-flex align-center mt-2"):
                            v3.VSelect(v_model=("save_folder",), items=("folder_items",), label="folder",
                                       density="compact", hide_details=True, variant="outlined",
                                       style="max-width: 110px")
                            v3.VTextField(v_model=("save_name",), label="save as", density="compact",
                                          hide_details=True, variant="outlined", classes="ml-2", id="save-name")
                        with html.Div(classes="d-flex align-center"):
                            v3.VCheckbox(v_model=("save_overwrite",), label="overwrite", density="compact",
                                         hide_details=True)
                            v3.VBtn("Save", click=(app.ctrl.save_rig, "[save_name, save_folder, save_overwrite]"), size="small", color="primary",
                                    id="save-btn", prepend_icon="mdi-content-save")
                        v3.VAlert("{{ file_message }}", v_if="file_message", type=("file_message_type",),
                                  density="compact", variant="tonal", classes="mt-2 text-body-2", id="file-message")
                # --- camera
                with v3.VExpansionPanel(title="Camera & port", value="camera"):
                    with v3.VExpansionPanelText():
                        v3.VTextField(v_model=("c_rig_name",), label="rig name", density="compact",
                                      variant="outlined", hide_details="auto", error_messages=("err_c_rig_name",))
                        _num(v3, html, "Focal length", "c_focal_length_mm", 8, 105, 1, "mm")
                        _num(v3, html, "Aperture (f-number)", "c_f_number", 1.4, 22, 0.1, "")
                        with html.Div(classes="d-flex align-center mt-2"):
                            with v3.VBtnToggle(v_model=("c_port_kind",), mandatory=True, density="compact", color="primary",
                                               variant="outlined", divided=True):
                                v3.VBtn("dome", value="dome", size="small")
                                v3.VBtn("flat", value="flat", size="small")
                        _num(v3, html, "Port radius", "c_port_radius_m", 0.03, 0.2, 0.005, "m")
                        _num(v3, html, "Housing radius (keep-out sphere)", "c_housing_radius_m", 0.05, 0.3,
                             0.005, "m")
                # --- lights
                with v3.VExpansionPanel(title="Lights", value="lights"):
                    with v3.VExpansionPanelText():
                        with html.Div(classes="d-flex align-center"):
                            v3.VSelect(v_model=("light_index",), items=("light_items",), label="light",
                                       density="compact", hide_details=True, variant="outlined", id="light-sel")
                            v3.VBtn(icon="mdi-plus", size="small", variant="text", click=app.ctrl.add_strobe,
                                    title="add a strobe")
                            v3.VBtn(icon="mdi-lightbulb-on-outline", size="small", variant="text",
                                    click=app.ctrl.add_video, title="add a video light")
                            v3.VBtn(icon="mdi-delete", size="small", variant="text", click=(app.ctrl.remove_light, "[light_index]"),
                                    title="remove this light", disabled=("!has_lights",))
                        with html.Div(v_if="has_lights"):
                            v3.VTextField(v_model=("l_name",), label="name", density="compact", variant="outlined",
                                          hide_details="auto", classes="mt-2", error_messages=("err_l_name",))
                            html.Div("Arm (camera frame: 0° = image right, 90° = up)",
                                     classes="text-overline mt-1")
                            _num(v3, html, "Arm length (from the lens axis)", "l_arm_length_m", 0.13, 1.2, 0.01, "m")
                            _num(v3, html, "Arm angle", "l_arm_angle_deg", 0, 360, 1, "°")
                            _num(v3, html, "Forward of the lens (− = behind)", "l_arm_forward_m", -0.4, 0.4,
                                 0.01, "m")
                            html.Div("Aim", classes="text-overline mt-1")
                            with v3.VBtnToggle(v_model=("l_aim_mode",), mandatory=True, density="compact", color="primary",
                                               variant="outlined", divided=True):
                                v3.VBtn("yaw / pitch", value="angles", size="small")
                                v3.VBtn("at a point", value="point", size="small")
                            with html.Div(v_if="l_aim_mode == 'angles'"):
                                _num(v3, html, "Yaw (+ = towards image right)", "l_yaw_deg", -90, 90, 1, "°")
                                _num(v3, html, "Pitch (+ = up)", "l_pitch_deg", -60, 60, 1, "°")
                            with html.Div(v_if="l_aim_mode == 'point'", classes="d-flex mt-2"):
                                for var, lab in zip(("l_aim_r", "l_aim_u", "l_aim_f"), ("right", "up", "fwd")):
                                    v3.VTextField(v_model=(var,), id=var, label=f"{lab} (m)", type="number",
                                                  step=0.05, density="compact", variant="outlined",
                                                  hide_details=True, classes="mr-1")
                            v3.VAlert("{{ err_l_aim_f[0] }}", v_if="err_l_aim_f.length", type="error",
                                      density="compact", variant="tonal")
                            html.Div("Beam and output", classes="text-overline mt-1")
                            with html.Div(v_if="l_beam_mode == 'cone'"):
                                _num(v3, html, "Beam angle (full, at half intensity, in water)", "l_beam_angle_deg",
                                     20, 180, 1, "°")
                            html.Div("beam profile: {{ l_beam_profile }} (edit the file)", v_if="l_beam_mode != 'cone'",
                                     classes="rs-cap")
                            v3.VCombobox(v_model=("l_spectrum",), items=("spectrum_items",), label="spectrum",
                                         density="compact", variant="outlined", hide_details="auto", classes="mt-2",
                                         error_messages=("err_l_spectrum",))
                            with html.Div(v_if="l_kind == 'strobe'"):
                                with v3.VBtnToggle(v_model=("l_power_mode",), mandatory=True, density="compact",
                                                   color="primary", variant="outlined", divided=True):
                                    v3.VBtn("guide number", value="guide_number", size="small")
                                    v3.VBtn("energy", value="energy", size="small")
                                with html.Div(v_if="l_power_mode == 'guide_number'"):
                                    _num(v3, html, "Guide number (in air, ISO 100)", "l_guide_number_m", 5, 60, 1, "m")
                                with html.Div(v_if="l_power_mode == 'energy'"):
                                    _num(v3, html, "Flash energy", "l_flash_energy_J", 5, 300, 5, "J")
                                _num(v3, html, "Power setting (1 = full)", "l_power_fraction", 0.01, 1, 0.01, "")
                            with html.Div(v_if="l_kind == 'video'"):
                                _num(v3, html, "Luminous flux", "l_lumens", 200, 20000, 100, "lm")
                # --- water
                with v3.VExpansionPanel(title="Water", value="water"):
                    with v3.VExpansionPanelText():
                        with html.Div(classes="d-flex align-center"):
                            v3.VSelect(v_model=("water",), items=("water_items",), label="water type",
                                       density="compact", hide_details=True, variant="outlined", id="water-sel")
                            html.Div(style=("{background: water_rgb, width: '34px', height: '34px', "
                                            "borderRadius: '6px', marginLeft: '8px', border: '1px solid #999'}",),
                                     title="colour of the water at this depth")
                        v3.VSwitch(v_model=("use_constituents",), label="set constituents", density="compact",
                                   hide_details=True, color="primary")
                        with html.Div(v_if="use_constituents", classes="d-flex flex-wrap"):
                            for var, lab in (("chl", "chlorophyll mg/m³"), ("cdom", "CDOM a440 1/m"),
                                             ("small", "small particles ppm"), ("large", "large particles ppm")):
                                v3.VTextField(v_model=(var,), label=lab, type="number", density="compact",
                                              variant="outlined", hide_details=True, placeholder="preset",
                                              style="width: 48%; margin: 1%")
                        v3.VSelect(v_model=("particles",), items=("particle_items",),
                                   label="marine snow (particles lit as specks)", density="compact",
                                   hide_details=True, variant="outlined", classes="mt-2", id="particles-sel")
                        _num(v3, html, "Depth (tints the 3-D view)", "depth_m", 0, 60, 1, "m", err=False)
                # --- subject
                with v3.VExpansionPanel(title="Subject", value="subject"):
                    with v3.VExpansionPanelText():
                        v3.VSelect(v_model=("target",), items=("target_items",), label="target", density="compact",
                                   hide_details=True, variant="outlined")
                        _num(v3, html, "Distance (lens → subject)", "distance_m", 0.3, 6, 0.05, "m", err=False)
                        v3.VSelect(v_model=("target_size",), items=("target_size_items",), label="target size",
                                   density="compact", hide_details=True, variant="outlined", classes="mt-2")
                        html.Div("'fills' scales the chart with distance so that its patches stay measurable",
                                 classes="rs-cap")
                # --- sensor
                with v3.VExpansionPanel(title="Camera body & exposure", value="sensor"):
                    with v3.VExpansionPanelText():
                        v3.VSelect(v_model=("sensor",), items=("sensor_items",), label="sensor", density="compact",
                                   hide_details=True, variant="outlined")
                        with v3.VBtnToggle(v_model=("exposure_mode",), mandatory=True, density="compact", color="primary",
                                           variant="outlined", divided=True, classes="mt-2"):
                            v3.VBtn("auto / TTL", value="auto", size="small")
                            v3.VBtn("manual", value="manual", size="small")
                        with html.Div(v_if="exposure_mode == 'manual'"):
                            _num(v3, html, "Shutter 1/x s", "shutter_inv", 1, 1000, 1, "1/s", slider=False, err=False)
                            _num(v3, html, "ISO", "iso", 50, 12800, 50, "", slider=False, err=False)
                            _num(v3, html, "Strobe output", "flash_pct", 0, 100, 1, "%", err=False)
                        v3.VSelect(v_model=("white_balance",), items=("wb_items",), label="white balance",
                                   density="compact", hide_details=True, variant="outlined", classes="mt-2")

        # ------------------------------------------------------------ main
        with layout.content:
            with v3.VContainer(fluid=True, classes="pa-3"):
                v3.VAlert("{{ message }}", v_if="message", type=("message_type",), density="compact",
                          variant="tonal", closable=True, classes="mb-2", id="message",
                          click_close="message = ''")
                with v3.VRow(dense=True):
                    with v3.VCol(cols=12, lg=6):
                        with v3.VCard(variant="outlined"):
                            with v3.VCardTitle(classes="d-flex align-center text-subtitle-1"):
                                html.Span("3-D layout")
                                v3.VSpacer()
                                v3.VBtn("from behind", size="x-small", variant="text", click=app.ctrl.view_behind,
                                        id="view-behind", title="look along the lens axis from behind the housing, "
                                                                "as the diver holds the rig")
                                v3.VBtn("reset view", size="x-small", variant="text", click=app.ctrl.reset_camera)
                            with html.Div(classes="rs-view"):
                                if app.view_mode == "client":
                                    view = vtk_widgets.VtkLocalView(app.plotter.ren_win)
                                else:
                                    # the interactor (made by the app, with the light handles) gets the mouse
                                    view = vtk_widgets.VtkRemoteView(app.plotter.ren_win, interactive_ratio=1,
                                                                     interactive_quality=70, still_quality=95)
                                app.ctrl.view_update = view.update
                            html.Div("Beams: cones at half the beam angle along each aim (selected light brighter). "
                                     "Frame: the lens's field of view in water. Ticks every 0.5 m on the axis. "
                                     + ("Drag a light's sphere to swing it on its arm (forward offset and aim kept; Shift: move freely); "
                                        "drag elsewhere to orbit, wheel to zoom."
                                      if app.view_mode == "server" else "Drag to orbit, wheel to zoom."), classes="rs-cap pa-2")
                    with v3.VCol(cols=12, lg=6):
                        with v3.VCard(variant="outlined"):
                            with v3.VCardTitle(classes="d-flex align-center text-subtitle-1"):
                                html.Span("{{ preview_title || 'Predicted photograph' }}", id="preview-title")
                                v3.VSpacer()
                                v3.VProgressCircular(v_if="preview_busy", indeterminate=True, size=18, width=2,
                                                     color="primary")
                            with html.Div(classes="px-3"):
                                html.Img(src=("preview_src",), classes="rs-img", id="preview-img",
                                         v_if="preview_src")
                                html.Div("{{ preview_info }} · gen {{ preview_gen }}", classes="rs-cap",
                                         id="preview-info")
                            with v3.VRow(dense=True, classes="px-3 pb-2"):
                                with v3.VCol(cols=12, md=7):
                                    _metrics_table(v3, html, "metric_rows", "m-")
                                with v3.VCol(cols=12, md=5):
                                    html.Div("Exposure", classes="text-overline")
                                    html.Div("{{ exposure_text }}", classes="text-body-2", id="exposure-text")
                                    html.Div("{{ render_message }}", classes="rs-cap mt-2", id="render-message")
                                    html.Div("How far to trust the preview", classes="text-overline mt-2")
                                    html.Div("{{ agreement_text }}", classes="rs-cap", id="agreement-text")
                # ------------------------------------------------ comparison
                with v3.VCard(variant="outlined", classes="mt-3"):
                    with v3.VCardTitle(classes="d-flex align-center flex-wrap text-subtitle-1"):
                        html.Span("Compare side by side", classes="mr-4")
                        v3.VSelect(v_model=("compare_mode",), items=("compare_mode_items",), density="compact",
                                   hide_details=True, variant="outlined", style="max-width: 300px", classes="mr-2",
                                   id="compare-mode")
                        v3.VSelect(v_if="compare_mode == 'waters'", v_model=("compare_waters",),
                                   items=("water_items",), multiple=True, chips=True, closable_chips=True,
                                   density="compact", hide_details=True, variant="outlined",
                                   style="max-width: 420px", label="waters (up to 4)", id="compare-waters")
                        v3.VTextField(v_if="compare_mode == 'distances'", v_model=("compare_distances",),
                                      density="compact", hide_details=True, variant="outlined",
                                      style="max-width: 260px", label="distances, m (up to 4)")
                        with html.Div(v_if="compare_mode == 'rigs'", classes="d-flex align-center"):
                            v3.VSelect(v_model=("compare_rig_b",), items=("compare_rig_items",), density="compact",
                                       hide_details=True, variant="outlined", style="min-width: 300px",
                                       label="rig B")
                        v3.VBtn("pin this rig as B", size="small", variant="tonal", classes="ml-2",
                                click=app.ctrl.pin_rig, prepend_icon="mdi-pin",
                                title="keep a copy of this rig to compare your edits against")
                        v3.VSpacer()
                        v3.VSwitch(v_model=("compare_auto",), label="live", density="compact", hide_details=True,
                                   color="primary", classes="mr-2")
                        v3.VBtn("Compare", size="small", click=app.ctrl.compare_now, variant="flat",
                                color="primary", id="compare-btn")
                    html.Div("{{ compare_info }}", classes="rs-cap px-4", id="compare-info")
                    with v3.VRow(dense=True, classes="pa-2"):
                        with v3.VCol(v_for="(cell, i) in compare_cells", key="i", cols=12, sm=6, md=3):
                            with v3.VCard(variant="tonal"):
                                v3.VCardSubtitle("{{ cell.title }}", classes="pt-2 text-body-1 font-weight-medium")
                                with html.Div(classes="px-2"):
                                    html.Img(src=("cell.src",), classes="rs-img", v_if="cell.src")
                                    html.Div("{{ cell.error }}", v_if="cell.error", classes="text-error text-body-2")
                                _metrics_table(v3, html, "cell.rows", None)
                                html.Div("{{ cell.exposure }}", classes="rs-cap px-2 pb-2")
                        with v3.VCol(cols=12, md=6):
                            html.Div("Contrast vs distance (solid) · backscatter share (dashed)",
                                     classes="text-overline")
                            html.Img(src=("compare_plot",), v_if="compare_plot", style="width: 100%; max-width: 620px",
                                     id="compare-plot")
