// The LTI pages that go on by themselves: a deep link's answer to the platform, and a
// launch opened outside the platform's frame (its own tab, a phone's LMS app), which
// needs no second tab to keep tagwall's cookie.
for (const form of document.querySelectorAll("form[data-autosubmit]")) form.submit();

const handover = document.querySelector("form[data-handover]");
if (handover && window.top === window.self) {
  handover.target = "_self";
  handover.submit();
}
