from django.contrib import admin
from django.urls import include, path, register_converter

from webfrontend import efficiency, params, views

# path values the store could never hold (ids beyond its integers, NUL, '..') match no URL: a 404
register_converter(params.IdConverter, "id")
register_converter(params.PathConverter, "relpath")
register_converter(params.SegmentConverter, "segment")

urlpatterns = [
    path("", views.overview, name="overview"),
    path("m/<id:machine_id>/t/<id:target_id>/", views.folder, name="folder-root"),
    path("m/<id:machine_id>/t/<id:target_id>/f/<relpath:folder>/", views.folder, name="folder"),
    path("testcases/<relpath:testcase>/", views.testcase_runs, name="testcase"),
    path("runs/<id:run_id>/", views.run_detail, name="run"),
    path("runs/<id:run_id>/plots.json", views.run_plots, name="run-plots"),
    path("runs/<id:run_id>/files/<relpath:relative>", views.run_file, name="run-file"),
    path("runs/<id:run_id>/consistency/", views.consistency, name="consistency"),
    path("runs/<id:run_id>/consistency/plots.json", views.consistency_plots, name="consistency-plots"),
    path("runs/<id:run_id>/override/", views.override, name="override"),
    path("compare/", views.compare, name="compare"),
    path("builds/compare/", views.compare_builds_page, name="compare-builds"),
    path("commits/<segment:target>/<segment:commit>/", views.commit_page, name="commit"),
    path("builds/<id:build_id>/", views.build_detail, name="build"),
    path("compare/plots.json", views.compare_plots, name="compare-plots"),
    path("history/<id:target_id>/<relpath:testcase>/plots.json", views.history_plots, name="history-plots"),
    path("history/<id:target_id>/<relpath:testcase>/", views.history, name="history"),
    path("sweeps/", views.sweeps, name="sweeps"),
    path("sweeps/<id:build_id>/<relpath:testcase>/<segment:name>.json", views.sweep_plots, name="sweep-plots"),
    path("regressions/", views.regressions, name="regressions"),
    path("scaling/", efficiency.scaling_page, name="scaling"),
    path("scaling/<id:build_id>/<relpath:testcase>/<segment:name>.json", efficiency.scaling_plots,
         name="scaling-plots"),
    path("breakdown/<id:target_id>/<relpath:testcase>/", efficiency.breakdown_history, name="breakdown"),
    path("runs/<id:run_id>/profile/", efficiency.profile_page, name="run-profile"),
    path("runs/<id:run_id>/profile.json", efficiency.profile_json, name="run-profile-json"),
    path("profiles/diff/", efficiency.profile_diff_page, name="profile-diff"),
    path("profiles/diff.json", efficiency.profile_diff_json, name="profile-diff-json"),
    path("matrix/", views.matrix, name="matrix"),
    path("matrix.json", views.matrix_json, name="matrix-json"),
    path("junit.xml", views.junit, name="junit"),
    path("accounts/", include("django.contrib.auth.urls")),
    path("admin/", admin.site.urls),
]

# error pages with nothing of the settings or the environment (templates 400/403/404/500.html); a 400
# names the parameter the dashboard could not use
handler400 = "webfrontend.views.bad_request"
