"""The desktop viewer: Qt code only.

``import auralize.viewer`` imports no Qt: the window lives in
:mod:`auralize.viewer.app` (imported by ``auralize view``).  What it shows and
records is Qt-free and shared with :mod:`auralize.simple`: the scene
(:mod:`auralize.scene.view`), detection runs (:mod:`auralize.scene.detection`),
the path recorder (:mod:`auralize.scene.recorder`), live listening
(:mod:`auralize.scene.listening`) and session files (:mod:`auralize.scene.session`).
"""
