from django.contrib import admin
from django.urls import include, path

from webfrontend import views

urlpatterns = [
    path("", views.overview, name="overview"),
    path("m/<int:machine_id>/t/<int:target_id>/", views.folder, name="folder-root"),
    path("m/<int:machine_id>/t/<int:target_id>/f/<path:folder>/", views.folder, name="folder"),
    path("testcases/<path:testcase>/", views.testcase_runs, name="testcase"),
    path("runs/<int:run_id>/", views.run_detail, name="run"),
    path("runs/<int:run_id>/plot/<int:series_id>.png", views.run_plot, name="run-plot"),
    path("runs/<int:run_id>/files/<path:relative>", views.run_file, name="run-file"),
    path("runs/<int:run_id>/consistency/", views.consistency, name="consistency"),
    path("runs/<int:run_id>/consistency/<int:result_id>.png", views.consistency_plot, name="consistency-plot"),
    path("runs/<int:run_id>/override/", views.override, name="override"),
    path("compare/", views.compare, name="compare"),
    path("compare/plot.png", views.compare_plot, name="compare-plot"),
    path("history/<int:target_id>/<path:testcase>/plot.png", views.history_plot, name="history-plot"),
    path("history/<int:target_id>/<path:testcase>/", views.history, name="history"),
    path("sweeps/", views.sweeps, name="sweeps"),
    path("sweeps/<int:build_id>/<path:testcase>/<str:name>.png", views.sweep_plot, name="sweep-plot"),
    path("junit.xml", views.junit, name="junit"),
    path("accounts/", include("django.contrib.auth.urls")),
    path("admin/", admin.site.urls),
]
