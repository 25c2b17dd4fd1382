"""The desktop viewer and its Qt-free parts.

``import auralize.viewer`` imports no Qt: the window lives in
:mod:`auralize.viewer.app` (imported by ``auralize view``); the scene
(:mod:`.scene`), detection (:mod:`.detection`), recording (:mod:`.recorder`),
live listening (:mod:`.listening`) and session files (:mod:`.session`) work
headless and are shared with :mod:`auralize.simple`.
"""
