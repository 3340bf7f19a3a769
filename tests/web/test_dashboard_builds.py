"""Failed builds as results on the dashboard and in JUnit: the build page (log, duration, compiler, options),
the overview's list of targets that do not build, and JUnit's failing test case ``build``."""
from __future__ import annotations

import xml.etree.ElementTree as ET
from datetime import datetime, timedelta, timezone

from django.test import TestCase
from django.urls import reverse

from harness.report.junit import build_failure_suite
from harness.store.models import Build, Machine, Target

T0 = datetime(2026, 3, 1, 12, 0, tzinfo=timezone.utc)
ERROR = "../src/src/finish.cpp:722:40: error: ordered comparison of pointer with integer zero"


class FailedBuildTest(TestCase):
    @classmethod
    def setUpTestData(cls):
        cls.machine = Machine.objects.create(name="ws")
        cls.target = Target.objects.create(name="liggghts-src", definition={"recipe": "cmake"})
        cls.failed = Build.objects.create(
            target=cls.target, machine=cls.machine, revision="3.8.0", commit="a" * 40, definition_hash="d",
            status="failed", started=T0, finished=T0 + timedelta(seconds=312.5),
            log="[ 40%] Building CXX object finish.cpp.o\n" + ERROR + "\nmake: *** [all] Error 2\n",
            details={"recipe": "cmake", "error": ERROR, "duration_s": 312.5, "jobs": 2,
                     "compiler": "c++ (Debian 12.2.0-14) 12.2.0",
                     "cmake_options": {"CMAKE_BUILD_TYPE": "Release", "ENABLE_VTK": "OFF"}, "patches": []})

    def test_build_page_shows_error_duration_compiler_options_and_log(self):
        page = self.client.get(reverse("build", args=[self.failed.pk])).content.decode()
        assert ERROR.replace("'", "&#x27;") in page or "finish.cpp:722:40: error:" in page
        assert "5 min 12 s" in page                       # 312.5 s
        assert "c++ (Debian 12.2.0-14) 12.2.0" in page
        assert "-DENABLE_VTK=OFF" in page and "2 jobs" in page
        assert "make: *** [all] Error 2" in page            # the log
        assert self.client.get(reverse("build", args=[self.failed.pk + 100])).status_code == 404

    def test_overview_lists_the_failure_until_a_later_build_succeeds(self):
        page = self.client.get(reverse("overview")).content.decode()
        assert "Failed builds" in page and reverse("build", args=[self.failed.pk]) in page
        assert "finish.cpp:722:40" in page
        Build.objects.create(target=self.target, machine=self.machine, revision="HEAD", commit="b" * 40,
                             definition_hash="d", status="complete", started=T0 + timedelta(hours=1),
                             finished=T0 + timedelta(hours=1, minutes=6), current=True)
        assert "Failed builds" not in self.client.get(reverse("overview")).content.decode()

    def test_junit_has_one_failing_test_case_build(self):
        suite = build_failure_suite(self.failed)
        text = ET.tostring(suite, encoding="unicode")
        parsed = ET.fromstring(text)
        cases = parsed.findall("testcase")
        assert parsed.get("name") == "liggghts-src/build" and parsed.get("failures") == "1"
        assert len(cases) == 1 and cases[0].get("name") == "build" and cases[0].get("time") == "312.500"
        failure = cases[0].find("failure")
        assert failure.get("type") == "build_failed" and failure.get("message") == ERROR
        assert "make: *** [all] Error 2" in cases[0].find("system-out").text
