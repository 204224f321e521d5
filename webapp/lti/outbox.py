"""The scores' way to the gradebooks: every score queued at End class is posted to its
line item until the platform accepts it. A failure waits (doubling from
``TAGWALL_LTI_RETRY_FIRST_S`` up to ``TAGWALL_LTI_RETRY_MAX_S``) and is tried again,
across restarts too: the scores wait in the database, never in memory."""

from __future__ import annotations

import asyncio
import contextlib
import logging

from sqlalchemy.exc import SQLAlchemyError

from webapp.core.threads import run_blocking
from webapp.lti.courses import claim_due_scores, course_class, score_failed, score_posted
from webapp.lti.platforms import get_platform
from webapp.lti.tool import LtiTool, ServiceError

log = logging.getLogger(__name__)

POLL_S = 5.0  # scores whose wait is over are looked for this often (and at End class)
LEASE_S = 60.0  # a score being posted is left to its process this long


class Outbox:
    """Posts the due scores; one per server process, each score claimed by one of them
    at a time."""

    def __init__(self, tool: LtiTool) -> None:
        self.tool = tool
        self._woken = asyncio.Event()

    def wake(self) -> None:
        """Look now (a class just ended)."""
        self._woken.set()

    async def run(self) -> None:
        while True:
            try:
                await self.send_due()
            except SQLAlchemyError as error:
                log.warning("scores for the gradebook not read: %s", error.__class__.__name__)
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._woken.wait(), POLL_S)
            self._woken.clear()

    async def send_due(self) -> None:
        db, settings = self.tool.db, self.tool.settings
        for pending in await run_blocking(claim_due_scores, db, LEASE_S):
            course = await run_blocking(course_class, db, pending.class_id)
            platform = None
            if course is not None:
                platform = await run_blocking(get_platform, db, course.platform_id)
            try:
                if course is None or platform is None or course.lineitem_url is None:
                    raise ServiceError("the class's platform or line item is gone")
                await self.tool.post_score(platform, course.lineitem_url, pending.score)
            except ServiceError as error:
                at = await run_blocking(
                    score_failed,
                    db,
                    pending,
                    str(error),
                    settings.lti_retry_first_s,
                    settings.lti_retry_max_s,
                )
                log.warning(
                    "score of %s in class %s not accepted (try %d, next at %s): %s",
                    pending.score.userId,
                    pending.class_id,
                    pending.attempts + 1,
                    f"{at:%H:%M:%S}",
                    error,
                )
                continue
            await run_blocking(score_posted, db, pending.id)
            log.info("score of %s in class %s posted", pending.score.userId, pending.class_id)
