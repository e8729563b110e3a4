#!/usr/bin/env python3
"""joint_state_publisher_gui (joint sliders) with a fix for Debian 12 (joint_state_publisher_gui 1.15.1).

The packaged GUI crashes at start-up with Python >= 3.10 / recent PyQt5:
    slider.setValue(RANGE/2)  ->  TypeError: setValue(self, a0: int): argument 1 has
    unexpected type 'float'
(fixed upstream by casting to int). This wrapper makes QSlider.setValue accept floats
(rounded) and then runs the same main program as the packaged executable.
"""

import signal
import sys
import threading

import rospy
from python_qt_binding.QtWidgets import QApplication, QSlider

_set_value = QSlider.setValue


def _set_value_rounded(self, value):
    _set_value(self, int(round(value)))


QSlider.setValue = _set_value_rounded

import joint_state_publisher  # noqa: E402  (after the patch on purpose)
import joint_state_publisher_gui  # noqa: E402


def main():
    rospy.init_node("joint_state_publisher_gui")
    app = QApplication(sys.argv)
    app.setApplicationDisplayName("Joint State Publisher")
    num_rows = joint_state_publisher.get_param("num_rows", 0)
    gui = joint_state_publisher_gui.JointStatePublisherGui(
        "Node: " + rospy.get_name(), joint_state_publisher.JointStatePublisher(), num_rows)
    gui.show()
    gui.sliderUpdateTrigger.emit()
    threading.Thread(target=gui.jsp.loop, daemon=True).start()
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    return app.exec_()


if __name__ == "__main__":
    try:
        sys.exit(main())
    except rospy.ROSInterruptException:
        pass
